#!/usr/bin/python3
"""Print an .ivo file without its checksum and with its version as its layout.

Versions 3 and 5, 4 and 6 are the same layouts with FNV-1a and XXH3-64
(octree/file.c), so the payloads of files written before and after the
checksum change compare byte for byte; between two files of one version, the
same payload means the same checksum.  Used by scripts/same-outputs.sh and
bench/writers.sh --same-values.

Usage: ivo_payload.py FILE.ivo > payload
"""
import struct
import sys

data = open(sys.argv[1], "rb").read()
version = struct.unpack("<I", data[8:12])[0] if len(data) >= 20 else 0
layout = {5: 3, 6: 4}.get(version, version)
sys.stdout.buffer.write(data[:8] + struct.pack("<I", layout) + data[12:-8])
