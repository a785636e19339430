"""``indoor params [--params FILE] [--set KEY=VALUE ...] [--toml] [-o FILE]``: every
reconstruction parameter with its value, unit and meaning, or the TOML parameter file.

Also the ``--params FILE`` / ``--set stage.key=value`` options that ``convert`` and
``segment`` share (:func:`add_params_options`, :func:`params_from_args`).
"""
from __future__ import annotations

import json

from ..errors import InputError
from ..fileutil import atomic_write_text
from ..params import Params, load_params, params_table, params_to_toml, with_settings
from .console import UsageError, plain

__all__ = ["add_params", "cmd_params", "add_params_options", "params_from_args", "format_table"]


def add_params_options(p) -> None:
    """Add ``--params FILE`` and ``--set KEY=VALUE`` (repeatable) to a subcommand parser."""
    p.add_argument("--params", default=None, metavar="FILE",
                   help="TOML parameter file (as written by `indoor params --toml`); the keys it has "
                        "replace the defaults")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="settings",
                   help="set one parameter, e.g. generic.cells.min_wall_area=0.7 (after --params; "
                        "repeatable; `indoor params` lists the keys)")


def params_from_args(args, extra=()) -> Params:
    """``with_settings(load_params(FILE) if FILE else Params(), --set values + extra)``.

    Raises
    ------
    UsageError
        The file cannot be read or is not a parameter file, or a key or value is bad (exit 2).
    """
    try:
        params = load_params(args.params) if args.params else Params()
        return with_settings(params, [*args.settings, *extra])
    except UsageError:
        raise
    except InputError as e:
        raise UsageError(e.problem, e.path) from None


def _value_text(value) -> str:
    if value is None:
        return "auto"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_value_text(v) for v in value) + "]"
    return str(value)


def format_table(rows) -> list[str]:
    """Aligned text lines: key, value, unit and the first line of the doc of each parameter."""
    head = ("parameter", "value", "unit", "meaning")
    cells = [(r.key, _value_text(r.value), r.unit or "-", (r.doc or "").strip().split("\n")[0]) for r in rows]
    w = [max(len(c[i]) for c in [head, *cells]) for i in range(3)]
    return [f"{k:<{w[0]}}  {v:<{w[1]}}  {u:<{w[2]}}  {d}".rstrip() for k, v, u, d in [head, *cells]]


def add_params(sub) -> None:
    """Add the ``params`` subcommand to an argparse subparsers object."""
    p = sub.add_parser("params", help="list every reconstruction parameter (value, unit, meaning) or "
                                      "write the TOML parameter file",
                       description="Print every parameter of the reconstruction with its value, unit and "
                                   "meaning, or with --toml the parameter file that --params reads. "
                                   "--params and --set start from a file and change keys first.")
    add_params_options(p)
    p.add_argument("--toml", action="store_true", help="print the TOML parameter file instead of the table")
    p.add_argument("-o", "--out", default=None, metavar="FILE", help="write to FILE instead of stdout")
    p.set_defaults(func=cmd_params)


def cmd_params(args) -> int:
    """Run ``indoor params``; returns 0 (2 for a bad --params file or --set key)."""
    params = params_from_args(args)
    rows = params_table(params)
    if args.toml:
        text = params_to_toml(params)
    elif getattr(args, "json", False):
        text = json.dumps([r._asdict() for r in rows], indent=2, default=plain) + "\n"
    else:
        text = "\n".join(format_table(rows)) + "\n"
    if args.out:
        atomic_write_text(args.out, text)
        if not getattr(args, "quiet", False):
            print(f"written to {args.out}")
    elif args.toml or getattr(args, "json", False) or not getattr(args, "quiet", False):
        print(text, end="")
    return 0
