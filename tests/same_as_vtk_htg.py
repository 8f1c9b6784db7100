#!/usr/bin/python3
"""Is a .htg of ivoct byte for byte what VTK's own writer writes?  Run with
/usr/bin/python3.

  same_as_vtk_htg.py FILE.htg...

Each file is read with vtkXMLHyperTreeGridReader and written again with
vtkXMLHyperTreeGridWriter in the mode the .htg writer reproduces (binary, UInt64
headers, LZ4): the XML (elements, attributes, indentation, each number as
vtkNumberToString writes it), the arrays and their compressed data must be the
same bytes.  VTK 9.1's writer drops the field data, so ours (a <FieldData> element
after the cell data) is left out of the comparison.  Exit 0 when every file is the
same, 1 with the first difference of each that is not.
"""
import os
import re
import sys
import tempfile

import vtk


def vtk_bytes(path):
    r = vtk.vtkXMLHyperTreeGridReader()
    r.SetFileName(path)
    r.Update()
    w = vtk.vtkXMLHyperTreeGridWriter()
    fd, out = tempfile.mkstemp(suffix=".htg")
    os.close(fd)
    try:
        w.SetFileName(out)
        w.SetInputData(r.GetOutput())
        w.SetDataModeToBinary()
        w.SetHeaderTypeToUInt64()
        w.SetCompressorTypeToLZ4()
        if not w.Write():
            raise RuntimeError("VTK's writer failed")
        return open(out, "rb").read()
    finally:
        os.unlink(out)


def main(paths):
    bad = 0
    for path in paths:
        ours = open(path, "rb").read()
        ours = re.sub(rb"\n    <FieldData>\n.*?\n    </FieldData>", b"", ours, flags=re.S)
        theirs = vtk_bytes(path)
        if ours == theirs:
            continue
        bad += 1
        at = next((i for i, (a, b) in enumerate(zip(ours, theirs)) if a != b),
                  min(len(ours), len(theirs)))
        line = ours.count(b"\n", 0, at) + 1
        print("%s: differs from VTK's writer at byte %d (line %d): ours %r, VTK's %r"
              % (path, at, line, ours[max(0, at - 40):at + 40], theirs[max(0, at - 40):at + 40]))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
