#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Craft a dth checkpoint that passes its checksum (docs/checkpoint.md, version 7), for the resume
checks of check_resume.sh: the layout walked independently of the library, one value changed, the
FNV-1a 64 recomputed.

  ckpt_patch.py FILE SECTION FIELD VALUE     a field of a section (state, policy, run, ...):
                                             VALUE an integer, or a double with a '.' or 'e'
  ckpt_patch.py FILE cli FIELD VALUE         a number field of dth run's "cli" blob (out.bytes, ...;
                                             VALUE up to 2^64 - 1)
  ckpt_patch.py FILE scene SECTION.KEY=VALUE the scene blob's key (set or added), the cli blob's
                                             scene.hash recomputed to match
"""
import struct
import sys

MASK = (1 << 64) - 1


def fnv(b, h=14695981039346656037):
    for x in b:
        h = ((h ^ x) * 1099511628211) & MASK
    return h


def u32(b, p):
    return struct.unpack_from("<I", b, p)[0]


def u64(b, p):
    return struct.unpack_from("<Q", b, p)[0]


def fields(b, p, on_field):
    """Walk a field list at p (u32 count, then fields), calling on_field(name, type, count, values)."""
    n = u32(b, p)
    p += 4
    for _ in range(n):
        nl = u32(b, p)
        name = b[p + 4:p + 4 + nl].decode()
        p += 4 + nl
        typ, count = u32(b, p), u64(b, p + 4)
        p += 12
        on_field(name, typ, count, p)
        p += count if typ == 3 else 8 * count
    return p


def sections(b, on_field):
    """Walk the state part: on_field(section, name, type, count, values). Returns the blobs' offset."""
    p = 24
    for _ in range(2):  # method, model
        p += 4 + u32(b, p)
    p += 8  # n

    def section(p):
        nl = u32(b, p)
        sec = b[p + 4:p + 4 + nl].decode()
        p += 4 + nl + 8  # name, veclen
        return fields(b, p, lambda *f: on_field(sec, *f))

    nsec = u32(b, p)
    p += 4
    for _ in range(nsec):
        p = section(p)
    p += 4 + u32(b, p)  # the regularizer's name
    p = section(p)
    has_run = u32(b, p)
    p += 4
    if has_run:
        p = section(p)
    return p


def blobs(b, p):
    out = []
    n = u32(b, p)
    p += 4
    for _ in range(n):
        nl = u32(b, p)
        name = b[p + 4:p + 4 + nl].decode()
        p += 4 + nl
        size = u64(b, p)
        out.append([name, bytearray(b[p + 8:p + 8 + size])])
        p += 8 + size
    return out


def number(text):
    if any(c in text for c in ".eEn"):
        return struct.pack("<d", float(text))
    v = int(text)
    return struct.pack("<Q", v) if v >= 1 << 63 else struct.pack("<q", v)


def main():
    path, where = sys.argv[1], sys.argv[2]
    b = bytearray(open(path, "rb").read())
    start = sections(b, lambda *f: None)
    bl = blobs(b, start)
    if where == "scene":
        key, value = sys.argv[3].split("=", 1)
        sec, k = key.split(".", 1)
        scene = next(x for x in bl if x[0] == "scene")
        lines, cur, done = scene[1].decode().split("\n"), None, False
        for i, line in enumerate(lines):
            if line.startswith("["):
                cur = line.strip("[]")
            elif cur == sec and line.split("=", 1)[0].strip() == k:
                lines[i], done = "%s=%s" % (k, value), True
        if not done:
            i = lines.index("[%s]" % sec) if "[%s]" % sec in lines else None
            if i is None:
                lines += ["[%s]" % sec, "%s=%s" % (k, value)]
            else:
                lines.insert(i + 1, "%s=%s" % (k, value))
        scene[1] = bytearray("\n".join(lines).encode())
        patch_cli(bl, "scene.hash", struct.pack("<Q", fnv(scene[1])))
    elif where == "cli":
        patch_cli(bl, sys.argv[3], number(sys.argv[4]))
    else:
        hit = []
        sections(b, lambda sec, name, typ, count, p: hit.append(p) if (sec, name) == (where, sys.argv[3]) else None)
        if not hit:
            sys.exit("no field %s.%s" % (where, sys.argv[3]))
        b[hit[0]:hit[0] + 8] = number(sys.argv[4])
    tail = bytearray(struct.pack("<I", len(bl)))
    for name, data in bl:
        tail += struct.pack("<I", len(name)) + name.encode() + struct.pack("<Q", len(data)) + data
    b = b[:start] + tail
    b[16:24] = struct.pack("<Q", len(b) + 8)
    b += struct.pack("<Q", fnv(b))
    open(path, "wb").write(b)


def patch_cli(bl, field, value):
    cli = next(x for x in bl if x[0] == "cli")
    hit = []
    fields(cli[1], 12, lambda name, typ, count, p: hit.append(p) if name == field else None)
    if not hit:
        sys.exit("no field %s in the cli blob" % field)
    cli[1][hit[0]:hit[0] + 8] = value


if __name__ == "__main__":
    main()
