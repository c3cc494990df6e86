"""One frozen, self-validating options record per command (issue 30, "one driver").

Each module here (``derive.py``, ``identify.py``, ...) holds the record of one command. Its
``__post_init__`` checks every field and raises the project's input error (exit code 2) with the
command line's wording (``--cutoff must be > 0``), so the typer command and ``minparam.<command>()``
build the same record, get the same messages, and call the same function in ``api/``.
"""
