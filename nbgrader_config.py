"""nbgrader's configuration when it runs from the repository root: the course's own, ``course/nbgrader_config.py``.

nbgrader reads ``nbgrader_config.py`` from the folder it runs in; this file lets every nbgrader command run
here as well as in ``course/``, with the same settings (a test checks that both resolve the same).
"""

import os

from traitlets.config.loader import PyFileConfigLoader

c = get_config()  # noqa: F821 -- injected by traitlets when it loads this file
COURSE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "course")
c.merge(PyFileConfigLoader("nbgrader_config.py", path=COURSE).load_config())
