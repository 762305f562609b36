"""The argument parser every `sparc-quad` command is built with: one help style, its own usage on a typo.

- help: every default shown one way, "(default: 10.0)", with numbers as the user types them (no
  `np.float64(...)` reprs; lists joined as they are entered); options whose default is "off" (False, None)
  show none unless their help says what the default means.
- typos: a subcommand reports unknown options itself, with its own usage line (argparse hands them up to
  the top-level parser, which prints the top-level usage).
- negative numbers: "-5,300" or "-0.01" after an option is a value, not an unknown option (argparse only
  takes "-5" and "-.5" as numbers).
"""

from __future__ import annotations

import argparse
import difflib
import numbers
import re
from collections.abc import Sequence
from pathlib import PurePath

_DEFAULT_IN_HELP = re.compile(r"\(default:? ")
_LOOSE_DEFAULT = re.compile(r"\(default %\(default\)s\)")


def show(value: object, sep: str = ",") -> str:
    """A default as the user would type it."""
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        return str(float(value))
    if isinstance(value, PurePath):
        return str(value)
    if isinstance(value, (list, tuple)):
        return sep.join(show(v) for v in value)
    return str(value)


class Formatter(argparse.HelpFormatter):
    """"(default: X)" on every option with a default, X formatted by `show`."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = _LOOSE_DEFAULT.sub("(default: %(default)s)", action.help or "")
        if "%(default)" in text or _DEFAULT_IN_HELP.search(text):
            return text
        default = action.default
        empty = isinstance(default, (list, tuple)) and not default  # a repeatable option given no times
        if default is None or default is False or empty or default is argparse.SUPPRESS or \
                not action.option_strings:
            return text
        if isinstance(action, (argparse._HelpAction, argparse._VersionAction)):
            return text
        return f"{text} (default: %(default)s)".strip()

    def _expand_help(self, action: argparse.Action) -> str:
        sep = " " if isinstance(action.nargs, int) or action.nargs in ("+", "*") else ","
        params = {k: v for k, v in dict(vars(action), prog=self._prog).items() if v is not argparse.SUPPRESS}
        for name, value in list(params.items()):
            if hasattr(value, "__name__"):
                params[name] = value.__name__
        if params.get("choices") is not None:
            params["choices"] = ", ".join(map(str, params["choices"]))
        if "default" in params:
            params["default"] = show(params["default"], sep)
        return self._get_help_string(action) % params


class RawDescriptionFormatter(Formatter, argparse.RawDescriptionHelpFormatter):
    """The same, with the description printed as written (paragraphs, examples)."""


class Parser(argparse.ArgumentParser):
    """The top-level parser (and, through `SubParser`, every subcommand's)."""

    is_sub = False

    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("formatter_class", Formatter)
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-\.?\d")

    def add_subparsers(self, **kwargs):  # type: ignore[override]
        kwargs.setdefault("parser_class", SubParser)
        return super().add_subparsers(**kwargs)

    def parse_known_args(self, args: Sequence[str] | None = None, namespace=None):  # type: ignore[override]
        if self.is_sub and self._subparsers is None and args is not None:
            unknown = self.unknown_options(args)
            if unknown:  # before any value is converted: `--workrs 2 spec.toml` is about --workrs, not "2"
                self.error(f"unrecognized arguments: {' '.join(unknown)}")
        ns, extras = super().parse_known_args(args, namespace)
        if self.is_sub and extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return ns, extras

    def unknown_options(self, args: Sequence[str]) -> list[str]:
        """The words of `args` that argparse would take for options this parser does not have (it would
        refuse them too, but only after converting the values around them, whose error then comes first):
        a word starting with '-' that is not a negative number, not `--`-separated, has no space, and is
        neither one of the options (before any '=') nor the start of a long option (argparse judges those)."""
        known = list(self._option_string_actions)
        out = []
        for word in args:
            if word == "--":
                break
            if not word.startswith("-") or len(word) < 2 or " " in word or \
                    self._negative_number_matcher.match(word):
                continue
            name = word.split("=", 1)[0]
            if name in known or (not name.startswith("--") and name[:2] in known):  # -v, -vv, -ofile
                continue
            if name.startswith("--") and any(o.startswith(name) for o in known):  # an abbreviation
                continue
            out.append(word)
        return out

    def error(self, message: str):  # type: ignore[override]
        """The error first, with a "did you mean" for a near miss, then one short usage line (argparse
        prints the whole usage block first, which buries the one line that matters)."""
        self.exit(2, f"{self.prog}: error: {message}{self.did_you_mean(message)}\n"
                     f"usage: {self.prog} [options]  ({self.prog} --help lists every option with its unit "
                     "and default)\n")

    def did_you_mean(self, message: str) -> str:
        """" (did you mean --kx?)" for an unknown option or choice close to a known one, else ""."""
        words: list[str] = []
        known: list[str] = []
        if message.startswith("unrecognized arguments:"):
            words = [w.split("=", 1)[0] for w in message.split(":", 1)[1].split() if w.startswith("-")]
            known = list(self._option_string_actions)
        else:
            m = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
            if m:
                words = [m.group(1)]
                known = [c.strip(" '") for c in m.group(2).split(",")]
        for word in words:
            near = difflib.get_close_matches(word, known, n=1, cutoff=0.6)
            if near:
                return f" (did you mean {near[0]}?)"
        return ""


class SubParser(Parser):
    is_sub = True

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        # the innermost subcommand's defaults win: `gap synth` for messages and log names
        self.set_defaults(command_name=self.prog.removeprefix("sparc-quad "))
