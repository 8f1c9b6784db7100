# Renders docs/mesh.png with ParaView's Python (pvpython; Debian: paraview, which
# conflicts with libvtk9-dev and python3-vtk9, so not on a build machine):
#   ivoct build scenes/horned-cube.ini --depth 7 --mesh hc.vtp
#   ivoct build scenes/horned-cube.ini --depth 9 --mesh-min-depth 4 --mesh-certified hc-cert.vtp
#   xvfb-run -a pvpython docs/mesh-figure.py hc.vtp hc-cert.vtp docs/mesh.png
# One horn of the horned cube where it leaves the box, seen from the same camera:
# left OpenVDB's mesh (--mesh), right the certified mesh (--mesh-certified) coloured
# by the depth of the cell that made each triangle. Surface With Edges, 1000x450.
#
# Without ParaView on the machine, a Debian 12 chroot holds it apart (as root):
#   debootstrap --variant=minbase bookworm /tmp/pvroot
#   mount -t proc proc /tmp/pvroot/proc
#   chroot /tmp/pvroot apt-get update
#   chroot /tmp/pvroot apt-get install -y --no-install-recommends paraview python3-paraview xvfb xauth
#   mkdir /tmp/pvroot/fig && cp hc.vtp hc-cert.vtp docs/mesh-figure.py /tmp/pvroot/fig/
#   chroot /tmp/pvroot xvfb-run -a pvpython /fig/mesh-figure.py /fig/hc.vtp /fig/hc-cert.vtp /fig/mesh.png
#
# Debian 12's ParaView 5.11 cannot read VTK XML files whose data are appended raw
# (ivoct's .vtp) once libexpat1 is 2.5.0-1+deb12u2 or later ("not well-formed
# (invalid token)"; its VTK lacks the fix Debian's vtk9 got, bug #1114938), so this
# script first copies such a file with its data moved inline as base64.
import base64
import os
import re
import struct
import sys
import tempfile

from paraview.simple import *

mesh_path, cert_path, png = sys.argv[1:4]
W, H = 500, 450  # each panel
CAMERA = dict(CameraPosition=[3.0, -0.6, 3.3], CameraFocalPoint=[1.45, 1.45, 1.45],
              CameraViewUp=[0, 0, 1], CameraViewAngle=30)
temporary = []


def readable(path):
    """path, or a copy of it with raw appended data moved inline (base64)."""
    data = open(path, "rb").read()
    start = data.find(b"<AppendedData")
    if start < 0 or b'encoding="raw"' not in data[start:start + 100]:
        return path
    base = data.index(b"_", data.index(b">", start)) + 1
    head = data[:start].decode("utf-8")
    fmt, size = ("<Q", 8) if 'header_type="UInt64"' in head else ("<I", 4)
    compressed = "compressor=" in head

    def word(pos):
        return struct.unpack(fmt, data[base + pos:base + pos + size])[0]

    def inline(m):  # header and data of an array, each base64 on its own
        tag, attrs = m.group(1), m.group(2)
        off = int(re.search(r'offset="(\d+)"', attrs).group(1))
        if compressed:
            blocks = word(off)
            header = size * (3 + blocks)
            body = sum(word(off + size * (3 + i)) for i in range(blocks))
        else:
            header, body = size, word(off)
        text = (base64.b64encode(data[base + off:base + off + header])
                + base64.b64encode(data[base + off + header:base + off + header + body]))
        attrs = re.sub(r'\s*offset="\d+"', "", attrs).replace('format="appended"', 'format="binary"')
        return "<%s%s>%s</%s>" % (tag, attrs.rstrip(), text.decode(), tag)

    head = re.sub(r'<(DataArray|Array)(\s[^>]*format="appended"[^>]*?)\s*/>', inline, head)
    fd, copy = tempfile.mkstemp(suffix=".vtp")
    with os.fdopen(fd, "w") as f:
        f.write(head + "</VTKFile>\n")
    temporary.append(copy)
    return copy


def panel(path, title):
    view = CreateView("RenderView")
    view.ViewSize = [W, H]
    view.OrientationAxesVisibility = 0
    view.Background = [1, 1, 1]
    try:
        view.UseColorPaletteForBackground = 0
    except AttributeError:
        pass
    mesh = XMLPolyDataReader(FileName=[readable(path)])
    mesh.UpdatePipeline()
    shown = Show(mesh, view)
    shown.Representation = "Surface With Edges"
    shown.EdgeColor = [0.4, 0.4, 0.4]
    triangles = mesh.GetDataInformation().GetNumberOfCells()
    text = Text(Text="%s\n%s triangles in all" % (title, format(triangles, ",")))
    label = Show(text, view)
    label.WindowLocation = "Upper Left Corner"
    label.FontSize = 20
    label.Justification = "Left"
    label.Color = [0, 0, 0]
    return view, mesh, shown


left, _, vdb = panel(mesh_path, "--mesh (OpenVDB)")
vdb.ColorArrayName = ["POINTS", ""]
vdb.DiffuseColor = [0.85, 0.55, 0.35]

right, cert, shown = panel(cert_path, "--mesh-certified")
ColorBy(shown, ("CELLS", "depth"))
lo, hi = cert.CellData["depth"].GetRange()
lut = GetColorTransferFunction("depth")
lut.ApplyPreset("Viridis (matplotlib)", True)
lut.AutomaticRescaleRangeMode = "Never"
lut.RescaleTransferFunction(lo - 0.5, hi + 0.5)  # one colour per depth
lut.Discretize = 1
lut.NumberOfTableValues = int(hi - lo + 1)
shown.SetScalarBarVisibility(right, True)
bar = GetScalarBar(lut, right)
bar.Title = "cell depth"
bar.ComponentTitle = ""
bar.TitleColor = bar.LabelColor = [0, 0, 0]
bar.TitleFontSize = bar.LabelFontSize = 16
bar.UseCustomLabels = 1
bar.CustomLabels = [float(d) for d in range(int(lo), int(hi) + 1)]
bar.AddRangeLabels = 0
bar.RangeLabelFormat = bar.LabelFormat = "%.0f"
bar.WindowLocation = "Any Location"
bar.Position = [0.86, 0.06]
bar.ScalarBarLength = 0.4

layout = CreateLayout("mesh")
cell = layout.SplitHorizontal(0, 0.5)
AssignViewToLayout(view=left, layout=layout, hint=1)
AssignViewToLayout(view=right, layout=layout, hint=2)
for view in (left, right):
    Render(view)  # the first render resets the camera: set it afterwards
    for key, value in CAMERA.items():
        setattr(view, key, value)
    Render(view)
SaveScreenshot(png, layout, ImageResolution=[2 * W, H], SeparatorWidth=2,
               SeparatorColor=[0.6, 0.6, 0.6], CompressionLevel="9")
for copy in temporary:
    os.remove(copy)
