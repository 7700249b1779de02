"""The command-line programs: ``evaluate.py`` / ``hev-evaluate`` (:mod:`.evaluate`, subcommands
``run``, ``benchmark``, ``paper``, ``performance``, one module each) and ``train.py`` / ``hev-train``
(:mod:`.train`). Each ``main(argv)`` returns the exit status; errors in the input are one line on
stderr (:mod:`.errors`); usage errors are one line too, and every ``--help`` shows the defaults and
examples (:mod:`.parsing`)."""
