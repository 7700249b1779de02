"""The command-line programs: ``evaluate.py`` / ``hev-evaluate`` (:mod:`.evaluate`, its subcommands in :mod:`.run`
and :mod:`.tasks`) and ``train.py`` / ``hev-train`` (:mod:`.train`). Each ``main(argv)`` returns the exit status;
errors in the input are one line on stderr, usage errors one line too, and every ``--help`` shows the defaults and
examples (:mod:`.errors`)."""
