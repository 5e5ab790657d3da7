"""``python -m twig_ecs`` runs the ``twig`` command line."""

import sys

from twig_ecs.cli import main

sys.exit(main())
