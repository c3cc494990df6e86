"""The library layer behind ``import minparam``: one function per command, typed frozen results.

Each function calls the same stage functions as the CLI command of the same name and keeps the
command's JSON report, so that ``result.to_dict()`` is exactly what ``minparam <command> --format
json`` prints for the same call (tests/test_api_cli_json.py).  Nothing here prints, exits or shows a
progress bar unless ``progress=True``; bad input raises the project's ``MinparamError`` subclasses
with the CLI's one-line message, and notes become ``warnings.warn(..., MinparamWarning)``.

Start-up: no module of this package imports numpy, sympy or typer at import time (``import
minparam`` stays cheaper than the CLI's start-up, benchmarks/bench_startup.py).
"""
