from stiction.cli import main

raise SystemExit(main())
