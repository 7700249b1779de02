"""The command-line programs: ``evaluate.py`` / ``hev-evaluate`` (:mod:`.evaluate`, its subcommands in
:mod:`.run`, :mod:`.paper` and :mod:`.tasks`) and ``train.py`` / ``hev-train`` (:mod:`.train`, :mod:`.sweep`). Each
``main(argv)`` returns the exit status; errors in the input are one line on stderr (:mod:`.errors`); usage errors are
one line too, and every ``--help`` shows the defaults and examples (:mod:`.parsing`)."""
