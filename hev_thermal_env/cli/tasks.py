"""The subcommands on the named tasks: ``evaluate.py reference`` (a task's reference values), ``dataset`` (an offline
Minari dataset of a strategy's episodes), ``bc`` (behaviour cloning on one, the datasets' usability check) and
``leaderboard`` (every method on every task with references: one Markdown page and a profile plot)."""

from __future__ import annotations

from pathlib import Path

from hev_thermal_env.evaluation import leaderboard as board
from hev_thermal_env.evaluation import references as refs
from hev_thermal_env.evaluation.datasets import SOURCES, training_routes, write_dataset
from hev_thermal_env.io import atomic_write_json
from hev_thermal_env.tasks import TRAINING_FAMILIES, get_task, held_out_cycles, list_tasks

REFERENCE_EXAMPLES = (
    "python evaluate.py reference --task hwfet               # recompute and store hwfet-v1's reference",
    "python evaluate.py reference --task hwfet beijing --check   # say whether the stored ones are current",
    "python evaluate.py reference --task bus-generalisation --jobs 2   # 18 routes, two solved at a time",
    "python evaluate.py reference --table docs/tasks.md   # the stored references as a table, into the docs",
)
DATASET_EXAMPLES = (
    "python evaluate.py dataset --source optimum --task hwfet          # hev-thermal/hwfet-v1/optimum-v0",
    "python evaluate.py dataset --source rule --routes 12 --root data/minari   # 12 training routes",
)
BC_EXAMPLES = (
    "python evaluate.py dataset --source optimum --routes 4 --families bus_launch bus_hilly",
    "python evaluate.py bc --dataset hev-thermal/train-paper/optimum-v0 --tasks hwfet beijing "
    "--results-dir results/leaderboard_bc",
    "python evaluate.py leaderboard --results results/leaderboard_bc --out docs/leaderboard.md",
)
LEADERBOARD_EXAMPLES = (
    "python evaluate.py leaderboard --out docs/leaderboard.md          # every task with references",
    "python evaluate.py leaderboard --results my_sac/ --out board.md    # with a method written elsewhere",
    "python evaluate.py leaderboard --tasks hwfet --methods rule ecms --results-dir /tmp/r --out /tmp/board.md",
)


def reference_arguments(p) -> None:
    p.add_argument("--task", nargs="+", metavar="NAME", help=f"tasks ({', '.join(list_tasks())})")
    p.add_argument("--dir", default=None, metavar="DIR",
                   help=f"where references are kept (default: {refs.REFERENCE_DIR})")
    p.add_argument("--check", action="store_true", help="only check the stored references (exit 1 if one is stale)")
    p.add_argument("--jobs", type=int, default=1, metavar="N",
                   help="episodes solved at once, each in its own process on one thread (default 1)")
    p.add_argument("--table", nargs="?", const="-", default=None, metavar="FILE",
                   help="print the stored references of --task (default: every task) as a Markdown table, or put it "
                        "in FILE between the lines <!-- references:begin --> and <!-- references:end -->")


def reference(args) -> int:
    directory = Path(args.dir) if args.dir else None
    if args.table is not None:
        table = refs.references_table(args.task, directory)
        if args.table == "-":
            print(table, end="")
        else:
            refs.write_references_table(Path(args.table), table)
            print(f"wrote the references table to {args.table}")
        return 0
    if not args.task:
        raise ValueError("reference: --task NAME [NAME ...] is needed (unless --table)")
    if args.jobs < 1:
        raise ValueError(f"reference: --jobs must be at least 1, got {args.jobs}")
    tasks = [get_task(t) for t in args.task]
    if args.check:
        stale = 0
        for task in tasks:
            try:
                ref = refs.load_reference(task, directory)
                print(f"{task.id}: current (budget {ref['safety_budget_s']:g} s, {len(ref['episodes'])} episodes)")
            except (FileNotFoundError, refs.StaleReferenceError) as exc:
                stale += 1
                print(f"{task.id}: {exc}")
        return 1 if stale else 0
    for task in tasks:
        record = refs.compute_reference(task, progress=print, jobs=args.jobs)
        path = refs.save_reference(record, directory)
        print(f"{task.id}: safety budget {record['safety_budget_s']:g} s; wrote {path} ({record['wall_s']:.0f} s)")
    return 0


def dataset_arguments(p) -> None:
    p.add_argument("--source", required=True, choices=list(SOURCES), help="who drives (optimum = dp_thermal)")
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--task", metavar="NAME", help=f"a task ({', '.join(list_tasks())})")
    where.add_argument("--routes", type=int, metavar="N", help="N generated routes of the training families")
    p.add_argument("--families", nargs="+", default=None, metavar="FAMILY",
                   help=f"with --routes: the families, in turn ({', '.join(TRAINING_FAMILIES)})")
    p.add_argument("--scenario", default="paper", help="with --routes: the scenario (default: paper)")
    p.add_argument("--root", default=None, metavar="DIR",
                   help="datasets directory (default: $MINARI_DATASETS_PATH, else ~/.minari/datasets)")
    p.add_argument("--name", default=None, metavar="ID", help="dataset id (default: hev-thermal/<task>/<source>-v0)")
    p.add_argument("--seed", type=int, default=0, help="the random source's seed")


def dataset(args) -> int:
    if args.routes is not None and args.routes < 1:
        raise ValueError(f"--routes must be at least 1, got {args.routes}")
    routes = training_routes(args.routes, tuple(args.families or ())) if args.routes else None
    info = write_dataset(args.source, task=args.task, routes=routes, scenario=args.scenario, root=args.root,
                         seed=args.seed, dataset_name=args.name)
    print(f"{info['dataset_id']}: {info['episodes']} episodes, {info['steps']} steps, "
          f"{info['bytes'] / 1e6:.2f} MB in {info['path']} ({info['wall_s']:.1f} s)")
    return 0


def bc_arguments(p) -> None:
    p.add_argument("--dataset", required=True, metavar="ID", help="Minari dataset id (in $MINARI_DATASETS_PATH)")
    p.add_argument("--tasks", nargs="+", default=list_tasks(), metavar="NAME", help="tasks to score it on")
    p.add_argument("--epochs", type=int, default=60, help="passes over the dataset")
    p.add_argument("--seeds", type=int, nargs="+", default=[0], metavar="SEED",
                   help="fit seeds, fixed in advance (default: 0); each fit is one member of the family")
    p.add_argument("--method", default="bc (optimum, training routes)", help="its name on the leaderboard")
    p.add_argument("--results-dir", default="results/leaderboard_bc", metavar="DIR")
    p.add_argument("--policy", default=None, metavar="FILE",
                   help="also save the policy here (.pt; with several seeds, FILE's stem gets _seedS)")


def bc(args) -> int:
    import minari

    from hev_thermal_env.evaluation.submission import result_of_seeds
    from hev_thermal_env.training.fit import BCStrategy, save_bc, train_bc

    meta = minari.load_dataset(args.dataset).storage.metadata
    seen = {str(e["cycle"]).lower() for e in meta.get("hev_thermal_episodes", [])}
    task_cycles = {c.lower() for t in list_tasks() for c in get_task(t).cycles}
    if meta.get("hev_thermal_task") or seen & (set(held_out_cycles()) | task_cycles):
        raise ValueError(f"{args.dataset}: holds task or test cycles "
                         f"({sorted(seen & (set(held_out_cycles()) | task_cycles))[:3]} "
                         f"task {meta.get('hev_thermal_task')}); clone a dataset of training routes")
    if len(set(args.seeds)) != len(args.seeds):
        raise ValueError(f"--seeds: each seed once, got {args.seeds}")
    fits, reports = {}, []
    for seed in args.seeds:
        record, report = train_bc(args.dataset, epochs=args.epochs, seed=seed)
        print(f"seed {seed}: fitted on {report['pairs']} pairs in {report['wall_s']} s: MSE {report['mse_first']} -> "
              f"{report['mse_last']} (action variance {report['action_variance']})")
        if args.policy:
            path = Path(args.policy)
            save_bc(record, path if len(args.seeds) == 1 else path.with_name(f"{path.stem}_seed{seed}{path.suffix}"))
        fits[seed] = BCStrategy(record, label=args.method)
        reports.append(report)
    training = {"wall_clock_s_per_seed": [float(r["wall_s"]) for r in reports], "fits": reports}
    for name in args.tasks:
        task = get_task(name)
        result = result_of_seeds(task, fits, args.method, training=training,
                                 track="guided")  # fitted to its dataset's actions alone
        path = atomic_write_json(Path(args.results_dir) / task.id / "bc.json", result)
        print(f"{task.id}: {len(result['episodes'])} episodes in {result['wall_clock_s']:.1f} s -> {path}")
    return 0


def leaderboard_arguments(p) -> None:
    p.add_argument("--tasks", nargs="+", default=None, metavar="NAME",
                   help="tasks (default: every task with a current reference)")
    p.add_argument("--methods", nargs="+", default=list(board.METHODS), metavar="STRATEGY",
                   help=f"this package's methods to run (default: {' '.join(board.METHODS)})")
    p.add_argument("--results", nargs="+", default=[], metavar="PATH",
                   help="more result files (or directories of them), e.g. of a method written elsewhere")
    p.add_argument("--results-dir", default="results/leaderboard", metavar="DIR",
                   help="where the package's methods' result files are kept")
    p.add_argument("--references", default=None, metavar="DIR", help="references directory (default: the package's)")
    p.add_argument("--out", default="docs/leaderboard.md", metavar="FILE", help="the page")
    p.add_argument("--no-plot", action="store_true", help=f"skip {board.PROFILE_FILE}")


def leaderboard(args) -> int:
    stored = Path(args.references) if args.references else None
    ready, missing = [], []
    for t in [get_task(t).id for t in (args.tasks or list_tasks())]:
        try:
            refs.load_reference(t, stored)
            ready.append(t)
        except (FileNotFoundError, refs.StaleReferenceError) as exc:
            if args.tasks:
                raise
            missing.append(board.missing_text(t, exc))
    paths = board.ensure_results(Path(args.results_dir), ready, args.methods, progress=print, references=stored)
    entries, more_missing = board.score_files([*paths, *args.results], stored)
    out = board.write_leaderboard(entries, [*missing, *more_missing], Path(args.out), plot=not args.no_plot)
    print(f"{len(entries)} results on {len({e['task'] for e in entries})} tasks; wrote {out}")
    for m in missing + more_missing:
        print(f"left out: {m}")
    return 0


COMMANDS = {
    "reference": ("a task's reference values: r0, the optimum's cost, the safety budget",
                  "Run the thermal optimum and engine_only on every episode of a named task and store their costs, "
                  "final SOCs, safety costs and the optimum's frontier with the physics fingerprint and the task's "
                  f"digest; safety budget: {refs.BUDGET_RULE}.", REFERENCE_EXAMPLES, reference_arguments, reference),
    "dataset": ("a Minari dataset of a strategy's episodes (offline RL)",
                "Drive a task's episodes (or generated training routes) with a source strategy through Minari's "
                "DataCollector and write the dataset, its card filled (physics fingerprint, task id and digest or "
                "the routes, each episode's reset arguments).", DATASET_EXAMPLES, dataset_arguments, dataset),
    "bc": ("behaviour cloning on a Minari dataset, scored on tasks",
           "Fit a small MLP to a dataset's actions (once per seed) and write the seed family's result file on each "
           "task (RESULTS_DIR/<task>/bc.json) for the leaderboard. The dataset must come from training routes: one "
           "with a task's cycles is refused.", BC_EXAMPLES, bc_arguments, bc),
    "leaderboard": ("every method on every task: normalised score, safety cost, profile plot",
                    "Run this package's methods on every task that has current references (their result files are "
                    "kept in --results-dir and reused), add the result files of --results, and write the page --out "
                    f"with {board.PROFILE_FILE} beside it.", LEADERBOARD_EXAMPLES, leaderboard_arguments, leaderboard),
}
