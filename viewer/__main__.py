import sys

from cellgl.viewer import main

sys.exit(main())
