"""Command-line interface: one typer module per command, joined in app.py."""
