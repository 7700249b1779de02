"""Every command and Python snippet of the README and the docs pages runs as written, in a copy of the checkout.

Each ```bash block runs line by line, in order, in its own copy of the checkout (without the
package sources, so every command imports the package under test): a user pastes a block into a
fresh clone. Progress bars stay on, as the user sees them. A command's leading ``python`` is the
interpreter running this suite, and a console script (``hev-evaluate``, ``tensorboard``, ...) the one
installed beside it, so the suite checks the environment it runs in, activated or not. The only
other changes, each listed in ``ADJUSTMENTS`` and each required to match a README line (so none can
go stale silently):

* ``pip install -e ".[dev]" && CMD`` and ``pip install -e . && CMD``: the suite runs in the installed environment,
  so it runs ``CMD`` only (it never installs anything);
* ``python -m pytest -q`` and ``python -m pytest -q --full``, the test commands, are this suite: they
  are not run again from inside it; ``.ci/run`` must run the README's full-suite line exactly;
* ``--timesteps N``: training budgets shrink to ``TINY_TIMESTEPS`` (one PPO rollout), the
  documented flag a user would change the same way.

The README's main job runs once per session (:func:`main_job`); every block that shows it reads that
run's output instead of running it again. Every ```python block runs as a script.
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
#: The main job needs the package alone (no test, docs or scale-out extras).
MAIN_INSTALL_PREFIX = "pip install -e . && "
TEST_COMMANDS = ("python -m pytest -q", "python -m pytest -q --full")
MAIN_JOB = "python evaluate.py benchmark --out results"
TINY_TIMESTEPS = 2048
ADJUSTMENTS = {
    "install prefix": INSTALL_PREFIX,
    "the main job's install prefix": MAIN_INSTALL_PREFIX,
    "fast tests": TEST_COMMANDS[0],
    "full suite": TEST_COMMANDS[1],
    "main job": MAIN_JOB,
}
#: Not copied into the working copy: the package sources (imported from the checkout under test),
#: version control, and outputs a previous run may have left.
NOT_COPIED = {
    ".git",
    "hev_thermal_env",
    "agents",
    "results",
    "runs",
    "site",
    ".cache",
    ".pytest_cache",
    ".ruff_cache",
    ".hypothesis",
    "build",
    "dist",
}
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


PAGES = [README, *sorted(DOCS.rglob("*.md"))]
TEXTS = {page.relative_to(ROOT).as_posix(): page.read_text(encoding="utf-8") for page in PAGES}
BASH_BLOCKS = [(name, i, block) for name, text in TEXTS.items() for i, block in enumerate(fenced(text, "bash"))]
README_COMMANDS = [c for block in fenced(TEXTS["README.md"], "bash") for c in command_lines(block)]
SNIPPETS = [(name, i, s) for name, text in TEXTS.items() for i, s in enumerate(fenced(text, "python"))]


def as_run(command: str) -> str | None:
    """What the suite runs for a command (None: not run, see the module docstring)."""
    for prefix in (INSTALL_PREFIX, MAIN_INSTALL_PREFIX):
        if command.startswith(prefix):
            command = command[len(prefix) :]
    if bare(command) in TEST_COMMANDS:
        return None
    command = re.sub(r"--timesteps \d+", f"--timesteps {TINY_TIMESTEPS}", command)
    program, _, rest = command.partition(" ")
    if program == "python":
        program = sys.executable
    elif (Path(sys.executable).parent / program).is_file():
        program = str(Path(sys.executable).parent / program)
    return f"{shlex.quote(program)} {rest}"


def declared_outputs(command: str) -> list[str]:
    """Files and folders a command says it writes: ``--out``, ``--json``, ``--trace``, ``--plot``, ``> FILE``."""
    words = shlex.split(command, comments=True)
    return [words[i + 1] for i, w in enumerate(words[:-1]) if w in ("--out", "--json", "--trace", "--plot", ">")]


def not_copied(root: Path):
    """The ``ignore`` of ``copy_checkout`` for a checkout at ``root``: ``__pycache__`` anywhere; at the top,
    :data:`NOT_COPIED` and any virtual environment (a directory with ``pyvenv.cfg``: a ``.venv`` in the checkout is
    gigabytes, and every block gets its own copy)."""
    def ignore(d: str, names: list[str]) -> list[str]:
        top = Path(d) == root
        return [n for n in names if n == "__pycache__"
                or (top and (n in NOT_COPIED or (Path(d) / n / "pyvenv.cfg").is_file()))]
    return ignore


def copy_checkout(dst: Path) -> Path:
    """A copy of the checkout without the package sources, as the working directory of a block."""
    shutil.copytree(ROOT, dst, ignore=not_copied(ROOT))
    return dst


def test_a_virtual_environment_in_the_checkout_is_not_copied(tmp_path):
    for d in (".venv", "env2", "docs", "docs/__pycache__", "results"):
        (tmp_path / d).mkdir()
    (tmp_path / ".venv" / "pyvenv.cfg").write_text("home = /usr\n")
    (tmp_path / "env2" / "pyvenv.cfg").write_text("home = /usr\n")
    ignore = not_copied(tmp_path)
    assert sorted(ignore(str(tmp_path), [".venv", "env2", "docs", "results", "README.md"])) == [".venv", "env2",
                                                                                            "results"]
    assert ignore(str(tmp_path / "docs"), ["__pycache__", "pyvenv.cfg"]) == ["__pycache__"]


def user_env() -> dict[str, str]:
    """The environment of a user's shell, with the package under test first on the import path."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), *filter(None, [env.get("PYTHONPATH")])])
    env.setdefault("MPLBACKEND", "Agg")
    return env


def run_shell(command: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", "-c", command], cwd=cwd, env=user_env(), capture_output=True, text=True, timeout=900)


@pytest.fixture(scope="session")
def main_job(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    """The README's main job, run once per session: the checkout copy it ran in, and the run."""
    cwd = copy_checkout(tmp_path_factory.mktemp("main_job") / "checkout")
    return cwd, run_shell(as_run(MAIN_JOB), cwd)


def test_readme_has_the_commands_this_test_adjusts():
    """Each adjustment matches a README command, so a renamed command cannot drop out unnoticed."""
    for name, marker in ADJUSTMENTS.items():
        assert any(marker in c for c in README_COMMANDS), f"{name}: no README command contains {marker!r}"
    top = [bare(c) for c in command_lines(fenced(TEXTS["README.md"], "bash")[0])]
    assert top == [MAIN_INSTALL_PREFIX + MAIN_JOB, *(INSTALL_PREFIX + c for c in TEST_COMMANDS)], top


def test_ci_runs_the_readme_full_suite_command():
    """The README's test lines are not run from inside the suite; CI runs the full-suite line, exactly as written."""
    full_line = INSTALL_PREFIX + TEST_COMMANDS[1]
    assert full_line in {bare(c) for c in README_COMMANDS}
    ci_lines = [
        bare(line).replace("pip install -q ", "pip install ")
        for line in (ROOT / ".ci" / "run").read_text().splitlines()
        if not line.startswith("#")
    ]
    assert full_line in ci_lines, f".ci/run does not run {full_line!r}"


def test_commands_run_with_the_suites_interpreter():
    assert as_run("python evaluate.py run") == f"{shlex.quote(sys.executable)} evaluate.py run"
    assert as_run(INSTALL_PREFIX + TEST_COMMANDS[0]) is None
    assert as_run("python train.py --timesteps 10000000").endswith(f"train.py --timesteps {TINY_TIMESTEPS}")


def worker_group(block: str) -> tuple:
    """Under pytest-xdist, the blocks that must share a worker with other tests (tests/conftest.py): those with the
    main job read the session's one run of it, and Ray's runtimes run one at a time (tests/test_scale_out.py)."""
    commands = [as_run(c) for c in command_lines(block)]
    if any(c is not None and bare(c) == bare(as_run(MAIN_JOB)) for c in commands):
        return (pytest.mark.xdist_group("main_job"),)
    if any(c is not None and "--executor ray" in c for c in commands):
        return (pytest.mark.xdist_group("ray"),)
    return ()


@pytest.mark.parametrize(
    "page, index, block",
    [pytest.param(page, i, b, marks=worker_group(b)) for page, i, b in BASH_BLOCKS],
    ids=[
        f"{page}#{i}:{bare(command_lines(b)[0])[:40]}" if command_lines(b) else f"{page}#{i}"
        for page, i, b in BASH_BLOCKS
    ],
)
def test_bash_block_runs_as_written(page: str, index: int, block: str, tmp_path: Path, request):
    commands = command_lines(block)
    assert commands, f"bash block {index} of {page} has no command"
    cwd = copy_checkout(tmp_path / "checkout")
    ran = 0
    for command in commands:
        to_run = as_run(command)
        if to_run is None:
            continue
        if bare(to_run) == bare(as_run(MAIN_JOB)):
            done, r = request.getfixturevalue("main_job")
            shutil.copytree(done / "results", cwd / "results", dirs_exist_ok=True)
        else:
            r = run_shell(to_run, cwd)
        where = f"{page}: command {command!r} (ran {to_run!r})"
        assert r.returncode == 0, f"{where}: exit {r.returncode}\n{r.stdout[-2000:]}\n{r.stderr[-3000:]}"
        assert "Traceback" not in r.stderr, f"{where}: {r.stderr[-3000:]}"
        for out in declared_outputs(command):
            path = cwd / out
            assert path.exists() and (path.is_dir() or path.stat().st_size > 0), f"{where}: wrote no {out}"
            if path.is_dir():
                assert any(path.iterdir()), f"{where}: {out} is empty"
        check_specific(command, r, cwd)
        ran += 1
    assert ran or all(bare(c).removeprefix(INSTALL_PREFIX) in TEST_COMMANDS for c in commands), (
        f"bash block {index} of {page}: no command ran"
    )


def check_specific(command: str, r: subprocess.CompletedProcess, cwd: Path) -> None:
    """What a few commands promise beyond writing their outputs."""
    words = shlex.split(command, comments=True)
    if "tools.parameters_page" in command:
        assert (cwd / "docs" / "parameters.md").read_text() == (DOCS / "parameters.md").read_text(), (
            "docs/parameters.md is not what `python -m tools.parameters_page` writes: regenerate it"
        )
    if words[:2] == ["python", "train.py"] and "--resume" not in words:
        assert "%" in r.stderr + r.stdout, "no progress bar in the training output"


@pytest.mark.xdist_group("main_job")
def test_readme_table_is_the_main_jobs(main_job):
    """The README's table is the table the main job writes (``results/results.md``), row for row."""
    cwd, r = main_job
    assert r.returncode == 0, r.stderr[-3000:]
    rows = [line for line in (cwd / "results" / "results.md").read_text().splitlines() if line.startswith("| ")]
    readme_rows = [line for line in TEXTS["README.md"].splitlines() if line.startswith("| ")]
    assert readme_rows == rows, "the README's table is not the main job's results.md: copy it from there"


@pytest.mark.parametrize("source, index, snippet", SNIPPETS, ids=[f"{s}#{i}" for s, i, _ in SNIPPETS])
def test_python_snippet_runs_as_written(source: str, index: int, snippet: str, tmp_path: Path):
    script = tmp_path / "snippet.py"
    script.write_text(snippet, encoding="utf-8")
    r = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, env=user_env(), capture_output=True, text=True, timeout=600
    )
    assert r.returncode == 0, f"{source}, python block {index}:\n{snippet}\n{r.stderr[-3000:]}"


def test_readme_links_the_documentation_site():
    assert "mkdocs build --strict" in TEXTS["README.md"] and "docs/index.md" in TEXTS["README.md"]
