from minparam_cli.cli.app import entry

raise SystemExit(entry())
