# SPDX-License-Identifier: MIT
"""Tests of how the package is found and finds its library (run by meson test 'python' with test_dth.py):
`import dth` in a Python without numpy or cffi names what to install; libdth.so is looked up beside the
package's own files first (pip install . puts it there), DTH_LIBRARY alone when set. The pip install
itself: python/check-pip.sh (meson test python-pip)."""
import os
import subprocess
import sys
import unittest

import dth
from dth import _ffi

PARENT = os.path.dirname(os.path.dirname(os.path.abspath(dth.__file__)))

# a Python in which module NAME cannot be imported, whatever is installed
BLOCK = """
import sys
class Block:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] == %r:
            raise ModuleNotFoundError("No module named %r", name=%r)
sys.meta_path.insert(0, Block())
sys.path.insert(0, %r)
import dth
"""


class ImportWithoutDependencies(unittest.TestCase):
    def check_missing(self, module):
        r = subprocess.run([sys.executable, "-c", BLOCK % (module, module, module, PARENT)],
                           capture_output=True, text=True)
        self.assertNotEqual(r.returncode, 0, "import dth succeeded without " + module)
        last = r.stderr.strip().splitlines()[-1]
        self.assertTrue(last.startswith("ImportError: dth needs the Python modules cffi and numpy"), last)
        for want in ("no module %r" % module, "python3-cffi python3-numpy", "-m venv --system-site-packages",
                     sys.executable):
            self.assertIn(want, last)

    def test_without_numpy(self):
        self.check_missing("numpy")

    def test_without_cffi(self):
        self.check_missing("cffi")


class LibraryLookup(unittest.TestCase):
    def setUp(self):
        self.saved = os.environ.pop("DTH_LIBRARY", None)

    def tearDown(self):
        if self.saved is not None:
            os.environ["DTH_LIBRARY"] = self.saved

    def test_package_directory_first(self):
        here = os.path.dirname(os.path.abspath(_ffi.__file__))
        c = _ffi.candidates()
        self.assertEqual(c[0], ("package", os.path.join(here, "libdth.so")))
        self.assertEqual(c[-1], ("dynamic linker", "libdth.so.0"))
        # every other place is found from the package's own path, never from the current directory
        for origin, path in c[:-1]:
            self.assertTrue(os.path.isabs(path), (origin, path))

    def test_dth_library_alone(self):
        os.environ["DTH_LIBRARY"] = "/nonexistent/libdth.so"
        try:
            self.assertEqual(_ffi.candidates(), [("DTH_LIBRARY", "/nonexistent/libdth.so")])
        finally:
            del os.environ["DTH_LIBRARY"]


if __name__ == "__main__":
    unittest.main()
