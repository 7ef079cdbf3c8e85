from samplehd.cli import main

raise SystemExit(main())
