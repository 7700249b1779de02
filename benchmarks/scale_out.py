#!/usr/bin/env python
"""Scaling out: wall time of a benchmark matrix with the local executor and with Ray, 1 and 2 workers.

The matrix is every strategy on five cycles (``hwfet``, ``udds``, ``us06``, ``wltc_3b``, ``beijing``) in the
``paper`` scenario, cells from ~0.01 s (ECMS) to about a minute (the thermal optimum on ``wltc_3b``). Each executor
runs it as ``evaluate.py benchmark`` would (``run_benchmark``, no plots), the thermal optimum solving its plans in
every run (``plan_cache=False``: a plan kept on disk by an earlier run would make the later ones free), the Ray runs
starting their own local runtime, so their wall time includes it. The matrix runs twice:
as shipped, where the DP cells split their physics over every core of the machine, and with the
DP strategies on one thread (``threads=1``), where one worker is one core. Within each, the four
result sets must be byte-identical. Ray's overhead is measured on its own: the start and stop of a local
runtime, and no-op tasks (one at a time: the latency of a task; 500 at once on 2 workers: the
throughput cost per task).

Writes JSON (default ``benchmarks/results/scale_out.json``): per run the wall time, the sum and
maximum of the cell times (``timings.json``), the speed-up over local with 1 worker, and the wall
time the model in the README predicts (start-up + max(sum of cells / workers, longest cell) +
cells × overhead per task / workers).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

import ray

from hev_thermal_env.agents import list_strategies
from hev_thermal_env.evaluation.benchmark import run_benchmark

CYCLES = ("hwfet", "udds", "us06", "wltc_3b", "beijing")
RUNS = (("local", 1), ("local", 2), ("ray", 1), ("ray", 2))
RESULT_FILES = ("results.csv", "results.json", "results.md")


def noop(x: int) -> int:
    return x


def ray_overhead(n_batch: int = 500, n_serial: int = 100) -> dict:
    """Start-up of a local 2-CPU runtime, and the cost of a task that does nothing."""
    t0 = time.perf_counter()
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="warning")
    start_s = time.perf_counter() - t0
    task = ray.remote(num_cpus=1)(noop)
    ray.get([task.remote(i) for i in range(20)])  # both workers up
    t0 = time.perf_counter()
    for i in range(n_serial):
        ray.get(task.remote(i))
    latency_s = (time.perf_counter() - t0) / n_serial
    t0 = time.perf_counter()
    ray.get([task.remote(i) for i in range(n_batch)])
    batch_s = (time.perf_counter() - t0) / n_batch
    t0 = time.perf_counter()
    ray.shutdown()
    return {"runtime_start_s": round(start_s, 3), "runtime_stop_s": round(time.perf_counter() - t0, 3),
            "task_latency_ms": round(1e3 * latency_s, 3), "task_overhead_ms_2_workers": round(1e3 * batch_s, 3),
            "n_serial": n_serial, "n_batch": n_batch}


def run_matrix(out: Path, executor: str, jobs: int, strategies: list[str], dp_threads: int | None) -> dict:
    threads = {} if dp_threads is None else {"threads": dp_threads}
    options = {"dp": dict(threads), "dp_thermal": {**threads, "plan_cache": False}}  # every run solves its plans
    t0 = time.perf_counter()
    run_benchmark(out, CYCLES, strategies, ("paper",), jobs=jobs, executor=executor, plots=False, options=options)
    wall = time.perf_counter() - t0
    cells = [r["wall_s"] for r in json.loads((out / "timings.json").read_text())["runs"]]
    return {"dp_threads": dp_threads or os.cpu_count(), "executor": executor, "workers": jobs, "cells": len(cells),
            "wall_s": round(wall, 2), "sum_cell_s": round(sum(cells), 2), "max_cell_s": round(max(cells), 2)}


def model_s(start_s: float, sum_cell_s: float, max_cell_s: float, cells: int, overhead_s: float, workers: int) -> float:
    """The README's model of a matrix's wall time on ``workers`` workers."""
    return start_s + max(sum_cell_s / workers, max_cell_s) + cells * overhead_s / workers


def add_model(row: dict, local_1: dict, overhead: dict) -> None:
    """Speed-up over the local 1-worker run and the model's prediction from its cell times."""
    row["speedup_vs_local_1"] = round(local_1["wall_s"] / row["wall_s"], 3)
    ray_run = row["executor"] == "ray"
    start = overhead["runtime_start_s"] + overhead["runtime_stop_s"] if ray_run else 0.0
    per_task = overhead["task_overhead_ms_2_workers"] / 1e3 if ray_run else 0.0
    row["model_wall_s"] = round(model_s(start, local_1["sum_cell_s"], local_1["max_cell_s"], row["cells"], per_task,
                                        row["workers"]), 2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", default=str(Path(__file__).parent / "results" / "scale_out.json"))
    args = ap.parse_args()
    strategies = list_strategies()
    load_at_start = list(os.getloadavg())
    print(f"matrix: {len(CYCLES)} cycles x {len(strategies)} strategies ({', '.join(strategies)}) x paper")
    overhead = ray_overhead()
    print(f"ray: runtime start {overhead['runtime_start_s']:.2f} s, task latency {overhead['task_latency_ms']:.2f} ms, "
          f"{overhead['task_overhead_ms_2_workers']:.2f} ms per task pipelined on 2 workers")
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for dp_threads in (None, 1):
            first = None
            for executor, jobs in RUNS:
                out = Path(tmp) / f"{executor}_{jobs}_{dp_threads}"
                row = run_matrix(out, executor, jobs, strategies, dp_threads)
                first = first or (out, row)
                row["results_identical_to_local_1"] = all(
                    (out / f).read_bytes() == (first[0] / f).read_bytes() for f in RESULT_FILES)
                add_model(row, first[1], overhead)
                runs.append(row)
                print(f"DP threads {row['dp_threads']}: {executor:>5} x {jobs}: {row['wall_s']:7.2f} s "
                      f"(x{row['speedup_vs_local_1']:.2f}; model {row['model_wall_s']:.1f} s; cells: sum "
                      f"{row['sum_cell_s']:.1f} s, longest {row['max_cell_s']:.1f} s)"
                      f"{'' if row['results_identical_to_local_1'] else '  RESULTS DIFFER'}")
    result = {"matrix": {"cycles": list(CYCLES), "strategies": strategies, "scenarios": ["paper"],
                         "cells": runs[0]["cells"]},
              "ray_overhead": overhead, "runs": runs,
              "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "ray": ray.__version__,
                          "load_average_1_5_15_start": load_at_start,
                          "load_average_1_5_15_end": list(os.getloadavg())},
              "note": "model_wall_s = start-up + max(sum of cell times / workers, longest cell) + cells x overhead "
                      "per task / workers, with the cell times of the local 1-worker run of the same DP threads; "
                      "dp_threads = threads of each DP cell's physics (the machine's cores as shipped, or 1)"}
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
