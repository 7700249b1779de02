"""The optimum benchmark's own bookkeeping (benchmarks/optimum.py) on hand-made cells."""

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_SPEC = importlib.util.spec_from_file_location("optimum_benchmark", ROOT / "benchmarks/optimum.py")
ob = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(ob)  # a script beside the benchmark, not a package module


def _cell(cycle: str, runs: dict[str, float], undecided: list[str]) -> dict:
    return {"cycle": cycle, "scenario": "paper", "optimum": {"soc_final": 0.65},
            "strategies": {n: {"soc_final": s} for n, s in runs.items()}, "outside_and_undecided": undecided}


def test_the_wide_re_solve_reaches_every_undecided_run():
    cells = [_cell("a", {"rule": 0.56, "ecms": 0.60}, ["rule"]),  # within WIDE: WIDE
             _cell("b", {"rule": 0.442, "dp": 0.40}, ["rule"]),  # 0.208 below: 0.228 -> 0.23; dp decided, ignored
             _cell("c", {"rule": 0.55}, [])]  # nothing undecided: no task
    tasks = ob._outside_tasks(cells)
    assert tasks == [("a", "paper", ("rule",), ob.WIDE), ("b", "paper", ("rule",), 0.23)]
    for cycle, _, names, halfwidth in tasks:
        cell = next(c for c in cells if c["cycle"] == cycle)
        lowest = min(cell["strategies"][n]["soc_final"] for n in names)
        assert cell["optimum"]["soc_final"] - halfwidth <= lowest - ob.WIDE_MARGIN + 1e-12
