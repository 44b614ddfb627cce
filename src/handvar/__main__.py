"""``python -m handvar``: the same command as ``handvar`` (`handvar.cli.main`)."""

from handvar.cli import main

if __name__ == "__main__":
    main(prog_name="handvar")
