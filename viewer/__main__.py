import sys

from viewer import main

sys.exit(main())
