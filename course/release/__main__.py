"""``python -m course.release [--homework hwN] DEST``: build a student package (``make modules`` runs this)."""

import sys

from .generator import main

sys.exit(main())
