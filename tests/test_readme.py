"""Every command and Python snippet of the README runs as written, in a copy of the checkout.

Each ```bash block runs line by line, in order, in its own copy of the checkout (without the
package sources, so every command imports the package under test): a user pastes a block into a
fresh clone. Progress bars stay on, as the user sees them. The only changes, each listed in
``ADJUSTMENTS`` and each required to match a README line (so none can go stale silently):

* ``pip install -e ".[dev]" && CMD``: the suite runs in the installed environment, so it runs ``CMD``
  only (it never installs anything);
* ``python -m pytest -q``, the test command, is this suite: it is not run again from inside
  itself; ``.ci/run`` must run the README's test line exactly;
* ``--timesteps N``: training budgets shrink to ``TINY_TIMESTEPS`` (one PPO rollout), the
  documented flag a user would change the same way;
* ``tensorboard --logdir DIR``: ``--inspect`` is added, which reads the same event files and
  prints their tags instead of starting a server.

Every ```python block of the README and of the docs pages runs as a script. Commands in the docs
pages' ```bash blocks must be README commands, so this test covers them too.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"

INSTALL_PREFIX = 'pip install -e ".[dev]" && '
TEST_COMMAND = "python -m pytest -q"
TINY_TIMESTEPS = 2048
ADJUSTMENTS = {
    "install prefix": INSTALL_PREFIX,
    "test command": TEST_COMMAND,
    "training budget": "--timesteps ",
    "tensorboard": "tensorboard --logdir ",
}
#: Not copied into the working copy: the package sources (imported from the checkout under test),
#: version control, and outputs a previous run may have left.
NOT_COPIED = {".git", "hev_thermal_env", "agents", "results", "runs", "site", ".cache", ".pytest_cache",
              ".ruff_cache", ".hypothesis", "build", "dist"}
FENCE = re.compile(r"^```(?P<lang>[\w-]*)[^\n]*\n(?P<body>.*?)^```", re.M | re.S)


def fenced(text: str, lang: str) -> list[str]:
    """The bodies of the fenced code blocks of ``lang`` in ``text``, in order."""
    return [m["body"] for m in FENCE.finditer(text) if m["lang"] == lang]


def command_lines(block: str) -> list[str]:
    """The commands of a bash block: its non-empty lines that are not comments, joined across ``\\``."""
    joined = re.sub(r"\\\n\s*", " ", block)
    return [line.strip() for line in joined.splitlines() if line.strip() and not line.strip().startswith("#")]


def bare(command: str) -> str:
    """A command without its trailing comment, spaces normalised."""
    return " ".join(re.split(r"\s#", command, maxsplit=1)[0].split())


README_TEXT = README.read_text(encoding="utf-8")
BASH_BLOCKS = fenced(README_TEXT, "bash")
README_COMMANDS = [c for block in BASH_BLOCKS for c in command_lines(block)]
SNIPPETS = [("README.md", i, s) for i, s in enumerate(fenced(README_TEXT, "python"))] + [
    (p.relative_to(ROOT).as_posix(), i, s) for p in sorted(DOCS.rglob("*.md"))
    for i, s in enumerate(fenced(p.read_text(encoding="utf-8"), "python"))]


def as_run(command: str) -> str | None:
    """What the suite runs for a README command (None: not run, see the module docstring)."""
    if command.startswith(INSTALL_PREFIX):
        command = command[len(INSTALL_PREFIX):]
    if bare(command) == TEST_COMMAND:
        return None
    command = re.sub(r"--timesteps \d+", f"--timesteps {TINY_TIMESTEPS}", command)
    if command.startswith(ADJUSTMENTS["tensorboard"]):
        command = f"{bare(command)} --inspect"
    return command


def declared_outputs(command: str) -> list[str]:
    """Files and folders a command says it writes: ``--out``, ``--json``, ``--trace``, ``--plot``, ``> FILE``."""
    words = shlex.split(command, comments=True)
    found = [words[i + 1] for i, w in enumerate(words[:-1]) if w in ("--out", "--json", "--trace", "--plot", ">")]
    if words[:2] == ["tensorboard", "--logdir"]:
        found.append(words[2])
    return found


@pytest.fixture
def checkout_copy(tmp_path: Path) -> Path:
    """A copy of the checkout without the package sources, as the working directory of a block."""
    dst = tmp_path / "checkout"
    shutil.copytree(ROOT, dst, ignore=lambda d, names: [n for n in names if n == "__pycache__"
                                                        or (Path(d) == ROOT and n in NOT_COPIED)])
    return dst


def user_env() -> dict[str, str]:
    """The environment of a user's shell, with the package under test first on the import path."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), *filter(None, [env.get("PYTHONPATH")])])
    env.setdefault("MPLBACKEND", "Agg")
    return env


def run_shell(command: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", "-c", command], cwd=cwd, env=user_env(), capture_output=True, text=True,
                          timeout=900)


def test_readme_has_the_commands_this_test_adjusts():
    """Each adjustment matches a README command, so a renamed command cannot drop out unnoticed."""
    for name, marker in ADJUSTMENTS.items():
        assert any(marker in c for c in README_COMMANDS), f"{name}: no README command contains {marker!r}"
    top = command_lines(BASH_BLOCKS[0])
    assert [c.startswith(INSTALL_PREFIX) for c in top] == [True, True], top
    assert bare(top[1]) == INSTALL_PREFIX + TEST_COMMAND


def test_ci_runs_the_readme_test_command():
    """The README's test line is not run from inside the suite; CI runs it, exactly as written."""
    test_line = bare(command_lines(BASH_BLOCKS[0])[1])
    ci_lines = [bare(line).replace("pip install -q ", "pip install ")
                for line in (ROOT / ".ci" / "run").read_text().splitlines() if not line.startswith("#")]
    assert test_line in ci_lines, f".ci/run does not run {test_line!r}"


@pytest.mark.parametrize("index", range(len(BASH_BLOCKS)),
                         ids=[bare(command_lines(b)[0])[:40] if command_lines(b) else "empty" for b in BASH_BLOCKS])
def test_readme_bash_block_runs_as_written(index: int, checkout_copy: Path):
    commands = command_lines(BASH_BLOCKS[index])
    assert commands, f"bash block {index} of README.md has no command"
    ran = 0
    for command in commands:
        to_run = as_run(command)
        if to_run is None:
            continue
        r = run_shell(to_run, checkout_copy)
        where = f"README command {command!r} (ran {to_run!r})"
        assert r.returncode == 0, f"{where}: exit {r.returncode}\n{r.stdout[-2000:]}\n{r.stderr[-3000:]}"
        assert "Traceback" not in r.stderr, f"{where}: {r.stderr[-3000:]}"
        for out in declared_outputs(command):
            path = checkout_copy / out
            assert path.exists() and (path.is_dir() or path.stat().st_size > 0), f"{where}: wrote no {out}"
            if path.is_dir():
                assert any(path.iterdir()), f"{where}: {out} is empty"
        check_specific(command, r, checkout_copy)
        ran += 1
    assert ran, f"bash block {index} of README.md: no command ran"


def check_specific(command: str, r: subprocess.CompletedProcess, cwd: Path) -> None:
    """What a few commands promise beyond writing their outputs."""
    words = shlex.split(command, comments=True)
    if words[:1] == ["tensorboard"]:
        assert "rollout/ep_rew_mean" in r.stdout, r.stdout[-2000:]
    if "hev_thermal_env.physics.docs" in command:
        assert (cwd / "docs" / "parameters.md").read_text() == (DOCS / "parameters.md").read_text(), \
            "docs/parameters.md is not what `python -m hev_thermal_env.physics.docs` writes: regenerate it"
    if words[:2] == ["python", "train.py"] and "--resume" not in words:
        assert "%" in r.stderr + r.stdout, "no progress bar in the training output"


@pytest.mark.parametrize("source, index, snippet", SNIPPETS, ids=[f"{s}#{i}" for s, i, _ in SNIPPETS])
def test_python_snippet_runs_as_written(source: str, index: int, snippet: str, tmp_path: Path):
    script = tmp_path / "snippet.py"
    script.write_text(snippet, encoding="utf-8")
    r = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=user_env(), capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, f"{source}, python block {index}:\n{snippet}\n{r.stderr[-3000:]}"


def test_docs_commands_are_readme_commands():
    """The docs pages show only commands that the README test runs."""
    readme = {bare(c) for c in README_COMMANDS}
    for page in sorted(DOCS.rglob("*.md")):
        for block in fenced(page.read_text(encoding="utf-8"), "bash"):
            for command in command_lines(block):
                assert bare(command) in readme, f"{page.relative_to(ROOT)}: {command!r} is not a README command"


def test_readme_links_the_documentation_site():
    assert "mkdocs build --strict" in README_TEXT or "docs/index.md" in README_TEXT
