from autobal.cli import main

raise SystemExit(main())
