import sys

from vggc_cp.cli import main

sys.exit(main())
