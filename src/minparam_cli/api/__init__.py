"""The library layer behind ``import minparam``: one function per command, typed frozen results.

Each command has one frozen options record (``api/options/<command>.py``) that checks itself with the
command line's messages; the typer command and ``minparam.<command>()`` both build it and call the same
function here, whose typed, frozen result's ``to_dict()`` is exactly what ``minparam <command> --format
json`` prints for the same call, a ``"schema"`` key first (tests/test_api_cli_json.py).  Nothing here prints, exits or shows a
progress bar unless ``progress=True``; bad input raises the project's ``MinparamError`` subclasses
with the CLI's one-line message, and notes become ``warnings.warn(..., MinparamWarning)``.

Start-up: no module of this package imports numpy, sympy or typer at import time (``import
minparam`` stays cheaper than the CLI's start-up, benchmarks/bench_startup.py).
"""
