import sys

try:  # a Ctrl-C while the command line itself is imported (cli.main handles it from then on)
    from autobal.cli import main
except KeyboardInterrupt:
    sys.stderr.write("autobal: interrupted (SIGINT)\n")
    raise SystemExit(130) from None

raise SystemExit(main())
