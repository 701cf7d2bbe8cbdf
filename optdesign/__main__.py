import sys

from optdesign.cli import main

sys.exit(main())
