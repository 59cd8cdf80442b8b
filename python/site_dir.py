# SPDX-License-Identifier: MIT
"""Print the directory this Python imports pure packages from for an install prefix (meson runs it
to place the package): on Debian the prefix /usr/local maps to /usr/local/lib/python3.X/dist-packages
(the 'posix_local' scheme, on sys.path by default; meson's own guess, /usr/local/lib/python3/
dist-packages, is not), any other prefix P to P/lib/python3.X/site-packages (for P = ~/.local that
is the user site directory, also on sys.path). Usage: site_dir.py PREFIX"""
import sys
import sysconfig

prefix = sys.argv[1].rstrip("/") or "/"
if prefix == "/usr/local" and "posix_local" in sysconfig.get_scheme_names():
    print(sysconfig.get_path("purelib", "posix_local", {"base": "/usr", "platbase": "/usr"}))
else:
    print(sysconfig.get_path("purelib", "posix_prefix", {"base": prefix, "platbase": prefix}))
