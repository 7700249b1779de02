"""The maintainers' hyperparameter sweep, ``python -m tools.sweep`` (:mod:`.cli`): Ray Tune over hyperparameters and
seeds, each trial a ``train.py`` run (:mod:`.trial`), Optuna's search and ASHA's stopping (:mod:`.study`), a report
per configuration over its seeds and the best trial exported (:mod:`.report`). It tuned the shipped hyperparameter
files (``benchmarks/results/sweep_*``); users tune theirs with rl-zoo3's optimiser (docs/scaling-out.md). Needs the
``ray`` extra; run from the checkout's root."""
