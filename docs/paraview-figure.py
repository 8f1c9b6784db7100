# Renders docs/paraview.png with ParaView's Python (pvpython; Debian: paraview, which
# conflicts with libvtk9-dev and python3-vtk9, so not on a build machine):
#   ivoct build scenes/sphere.ini --depth 6 --htg s.htg --vtu s.vtu --mesh s.vtp
#   xvfb-run -a pvpython docs/paraview-figure.py s.htg s.vtu s.vtp docs/paraview.png
# A slice of the HyperTreeGrid at x = 0.01 coloured by depth (the octree refines
# towards the surface), the surface leaves of the .vtu behind it (x < 0) and half
# of the mesh in front of it (y > 0).
import sys
from paraview.simple import *

htg_path, vtu_path, mesh_path, png = sys.argv[1:5]
view = CreateView("RenderView")
view.ViewSize = [640, 420]
view.OrientationAxesVisibility = 0
view.Background = [1, 1, 1]
try:
    view.UseColorPaletteForBackground = 0
except AttributeError:
    pass

htg = OpenDataFile(htg_path)
cut = Slice(Input=htg)
cut.SliceType = "Plane"
cut.SliceType.Origin = [0.01, 0, 0]  # not on a cell boundary
cut.SliceType.Normal = [1, 0, 0]
cut.Triangulatetheslice = 0
d = Show(cut, view)
d.Representation = "Surface With Edges"
ColorBy(d, ("CELLS", "depth"))
lut = GetColorTransferFunction("depth")
lut.ApplyPreset("Viridis (matplotlib)", True)
d.SetScalarBarVisibility(view, True)
bar = GetScalarBar(lut, view)
bar.Title = "depth"
bar.ComponentTitle = ""
bar.TitleColor = bar.LabelColor = [0, 0, 0]

vtu = OpenDataFile(vtu_path)
below = Clip(Input=vtu)
below.ClipType = "Plane"
below.ClipType.Normal = [1, 0, 0]
below.Invert = 1
v = Show(below, view)
v.Representation = "Surface With Edges"
ColorBy(v, ("CELLS", "depth"))

mesh = OpenDataFile(mesh_path)
above = Clip(Input=mesh)
above.ClipType = "Plane"
above.ClipType.Normal = [0, 1, 0]
above.ClipType.Origin = [0, 0, 0]
above.Invert = 0
m = Show(above, view)
m.ColorArrayName = ["POINTS", ""]
m.DiffuseColor = [0.85, 0.55, 0.35]

lut.AutomaticRescaleRangeMode = "Never"
lut.RescaleTransferFunction(1.0, 6.0)
d.EdgeColor = [0.3, 0.3, 0.3]
v.EdgeColor = [0.3, 0.3, 0.3]
Render(view)  # the first render resets the camera: set it afterwards
view.CameraPosition = [4.3, -2.75, 2.2]
view.CameraFocalPoint = [0, 0, 0]
view.CameraViewUp = [0, 0, 1]
Render(view)
SaveScreenshot(png, view, ImageResolution=[640, 420])
