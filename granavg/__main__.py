"""``python -m granavg`` runs the command line."""

import sys

from granavg.cli import main

sys.exit(main())
