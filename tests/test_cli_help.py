"""The ``--help`` of every program and subcommand (and of the workshop's sweep): renders, plain text (no ``%%``, no
reStructuredText), every default shown with its value, examples that parse."""

from __future__ import annotations

import argparse
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from hev_thermal_env.cli import train as cli_train
from hev_thermal_env.cli.evaluate import build_parser as evaluate_parser
from hev_thermal_env.cli.train import build_parser as train_parser
from tools.sweep.cli import build_parser as sweep_parser

ROOT = Path(__file__).resolve().parents[1]


SUBCOMMANDS = ("run", "benchmark", "paper", "performance")


def parsers() -> dict[str, argparse.ArgumentParser]:
    top = evaluate_parser()
    (sub,) = [a for a in top._actions if isinstance(a, argparse._SubParsersAction)]
    return {"evaluate.py": top, **{f"evaluate.py {name}": sub.choices[name] for name in SUBCOMMANDS},
            "train.py": train_parser(), "python -m tools.sweep": sweep_parser()}


def help_text(parser: argparse.ArgumentParser) -> str:
    return parser.format_help()


@pytest.mark.parametrize("name", ["evaluate.py", *(f"evaluate.py {s}" for s in SUBCOMMANDS), "train.py",
                                  "python -m tools.sweep"])
def test_help_is_plain_text_with_examples_and_defaults(name):
    parser = parsers()[name]
    text = help_text(parser)
    flat = " ".join(text.split())
    assert "%%" not in text and "``" not in text and "::" not in text, text
    for markup in (":mod:", ":func:", ":class:", ":data:", ".. "):
        assert markup not in text, markup
    assert "examples:\n  python " in text
    assert max(len(line) for line in text.splitlines()) <= 120
    for action in parser._actions:
        if not action.option_strings or action.help is argparse.SUPPRESS:
            continue
        default = action.default
        if default is None or default is False or default == [] or default is argparse.SUPPRESS:
            continue
        shown = " ".join(map(str, default)) if isinstance(default, list) else str(default)
        assert f"(default: {shown})" in flat, (action.option_strings, shown)


def test_strategies_are_named_with_the_ppo_path_form():
    for name in ("evaluate.py run", "evaluate.py benchmark"):
        flat = " ".join(help_text(parsers()[name]).split())
        assert "ppo:PATH" in flat and "dp_thermal" in flat and "ecms_thermal" in flat, name


def test_train_help_shows_the_defaults_of_the_hyperparameter_files():
    flat = " ".join(help_text(parsers()["train.py"]).split())
    for text in ("3000000 (ppo), 300000 (sac)", "32 (ppo), 4 (sac)", "bus_hilly bus_mixed bus_express (ppo)",
                 "validation_bus:20..29 (ppo)", "500000 (ppo), 25000 (sac)", "(default: 0)", "(default: ppo)"):
        assert text in flat, text
    assert "(default from the file)" not in flat


def test_benchmark_help_shows_its_defaults():
    flat = " ".join(help_text(parsers()["evaluate.py benchmark"]).split())
    for text in ("(default: hwfet beijing)", "(default: paper)", "(default: results)",
                 "(default: conventional engine_only rule ecms aecms ecms_thermal dp dp_thermal ppo)",
                 "(default: the number of cores"):
        assert text in flat, text


def example_lines(parser: argparse.ArgumentParser) -> list[list[str]]:
    """The example command lines of a parser's epilog, as argument lists (continuations joined, comments off)."""
    text = parser.epilog.split("examples:\n", 1)[1].split("\n\n")[0].replace("\\\n", " ")
    return [shlex.split(line.split("  #")[0]) for line in text.splitlines()]


def test_every_evaluate_example_parses():
    top = evaluate_parser()
    lines = [argv for p in parsers().values() if p is not parsers()["train.py"] for argv in example_lines(p)]
    evaluate_lines = [argv[2:] for argv in lines if argv[:2] == ["python", "evaluate.py"]]
    assert len(evaluate_lines) >= 15
    for argv in evaluate_lines:
        top.parse_args(argv)


def test_every_train_example_builds_a_valid_config(monkeypatch):
    """Each example (but --resume) gives a config that passes every check; no training starts."""
    built = []
    monkeypatch.setattr("hev_thermal_env.training.train",
                        lambda config, out, **kwargs: built.append(config) or ({}, out))
    lines = example_lines(train_parser())
    for argv in lines:
        if argv[:2] == ["python", "train.py"] and "--resume" not in argv:
            args = train_parser().parse_args(argv[2:])
            cli_train.run(args, " ".join(argv))
    assert len(built) == 4 and built[2]["algo"] == "sac" and built[3]["task"] == "bus-generalisation-v1"


def test_every_sweep_example_parses():
    lines = example_lines(sweep_parser())
    assert len(lines) == 4 and all(argv[:3] == ["python", "-m", "tools.sweep"] for argv in lines)
    for argv in lines:
        sweep_parser().parse_args(argv[3:])


def test_the_scripts_print_their_help():
    for command in (["evaluate.py", "benchmark", "--help"], ["train.py", "--help"], ["-m", "tools.sweep", "--help"]):
        r = subprocess.run([sys.executable, *command], cwd=ROOT, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0 and r.stdout.startswith("usage: ") and "examples:" in r.stdout, r.stderr
