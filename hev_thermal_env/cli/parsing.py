"""Argument parsing shared by the programs: usage errors in one line, help texts that show every default.

:class:`OneLineErrorParser` reports a usage error as ``PROG: error: MESSAGE (see --help)`` with exit
status 2 (argparse prints the whole usage first); subcommand parsers inherit it. :class:`HelpFormatter`
keeps descriptions and epilogs as written (the examples) and appends ``(default: VALUE)`` to every
option whose default is a value.
"""

from __future__ import annotations

import argparse
import textwrap
from collections.abc import Sequence


class OneLineErrorParser(argparse.ArgumentParser):
    """Usage errors in one line (``PROG: error: MESSAGE (see --help)``), exit status 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """``(default: VALUE)`` after options with a default value; descriptions and epilogs wrapped by
    paragraph, except paragraphs with indented lines (examples), which are kept as written.

    Options without a value default (``None``, an empty list, flags that are off) and help texts that
    already say what the default is are left alone.
    """

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        if (not action.option_strings or "default" in text or default is None or default is False
                or default is argparse.SUPPRESS or default == []):
            return text
        shown = " ".join(str(v) for v in default) if isinstance(default, (list, tuple)) else str(default)
        return f"{text} (default: {shown.replace('%', '%%')})"

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        paragraphs = []
        for par in text.split("\n\n"):
            lines = par.splitlines()
            if any(line[:1].isspace() for line in lines[1:]):
                paragraphs.append("\n".join(indent + line for line in lines))
            else:
                paragraphs.append(textwrap.fill(" ".join(par.split()), width, initial_indent=indent,
                                                subsequent_indent=indent))
        return "\n\n".join(paragraphs)


def examples(lines: Sequence[str]) -> str:
    """An epilog of example command lines."""
    return "examples:\n" + "\n".join(f"  {line}" for line in lines)


def refuse_settings_with_resume(args: argparse.Namespace, flags: Sequence[str], settings_file: str) -> None:
    """``--resume DIR`` takes every setting from ``DIR/settings_file``: a one-line error naming the setting
    options given beside it (those of ``flags`` that are not None)."""
    given = [f"--{f.replace('_', '-')}" for f in flags if getattr(args, f) is not None]
    if given:
        raise ValueError(f"--resume takes every setting from {args.resume}/{settings_file}; drop {' '.join(given)}")
