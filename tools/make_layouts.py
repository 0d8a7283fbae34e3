"""Write the published split of generated layouts, cmdp_pymunk/cases/layouts/*.toml, from the
rules in cmdp_pymunk/cases/generated.py. Run it after changing a rule (tests/test_layouts.py
checks the files match the generator):

    python tools/make_layouts.py [--out FOLDER]
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from cmdp_pymunk.cases.generated import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
