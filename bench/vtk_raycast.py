"""Times VTK's fixed-point CPU ray caster (vtkFixedPointVolumeRayCastMapper) on the
scene bench/run.sh gives rendr and Teem: the same volume, orthographic camera,
image size and sample step.

Usage: python vtk_raycast.py VOLUME.nrrd MODE SIZE STEP THREADS FR AT UP [OUT.png]
  VOLUME  a raw NRRD (3-D, short or float; index space = world space)
  MODE    mip (value maximum) or over (colour + opacity transfer function, Blinn-Phong)
  FR AT UP  three numbers each, quoted: look-from, look-at, up
  OUT.png the last frame, to look at
Prints "first_s later_s": the first frame (VTK's one-off work included: gradients and
normals, space-leaping tables) and the best of five later frames, in seconds.

VTK renders offscreen through OSMesa (set VTK_DEFAULT_OPENGL_WINDOW to
vtkOSOpenGLRenderWindow; Debian's libosmesa6). Trilinear interpolation only: VTK has
no B-spline reconstruction. The transfer function of `over` is bench/run.sh's LUT
(control points c.txt and a.txt), opacity per unit step as rendr's -us.
"""

import sys
import time

import numpy as np
import vtk
from vtk.util import numpy_support


def read_raw_nrrd(path):
    """The array of a raw-encoded NRRD (x fastest), as (sizes, flat array)."""
    with open(path, "rb") as f:
        raw = f.read()
    end = raw.index(b"\n\n")
    fields = {}
    for line in raw[:end].decode("latin-1").splitlines()[1:]:
        if line.startswith("#") or ":" not in line:
            continue
        k, v = line.split(":", 1)
        fields[k.strip()] = v.lstrip("=").strip()
    if fields.get("encoding") != "raw":
        sys.exit(f"{path}: needs raw encoding (unu save -e raw)")
    types = {"short": "<i2", "signed short": "<i2", "float": "<f4"}
    dt = np.dtype(types[fields["type"]])
    if fields.get("endian", "little") == "big":
        dt = dt.newbyteorder(">")
    sizes = [int(s) for s in fields["sizes"].split()]
    data = np.frombuffer(raw[end + 2 :], dtype=dt, count=int(np.prod(sizes)))
    return sizes, data.astype(dt.newbyteorder("<"))


def main():
    path, mode, size, step, threads = sys.argv[1:6]
    fr, at, up = ([float(x) for x in a.split()] for a in sys.argv[6:9])
    size, step, threads = int(size), float(step), int(threads)
    sizes, data = read_raw_nrrd(path)

    img = vtk.vtkImageData()
    img.SetDimensions(*sizes)
    img.SetSpacing(1, 1, 1)
    img.SetOrigin(0, 0, 0)
    arr = numpy_support.numpy_to_vtk(data, deep=True)
    img.GetPointData().SetScalars(arr)

    mapper = vtk.vtkFixedPointVolumeRayCastMapper()
    mapper.SetInputData(img)
    mapper.SetNumberOfThreads(threads)
    mapper.SetAutoAdjustSampleDistances(0)
    mapper.SetSampleDistance(step)
    mapper.SetImageSampleDistance(1.0)
    prop = vtk.vtkVolumeProperty()
    prop.SetInterpolationTypeToLinear()
    ctf = vtk.vtkColorTransferFunction()
    otf = vtk.vtkPiecewiseFunction()
    if mode == "mip":
        mapper.SetBlendModeToMaximumIntensity()
        lo, hi = float(data.min()), float(data.max())
        ctf.AddRGBPoint(lo, 0, 0, 0)
        ctf.AddRGBPoint(hi, 1, 1, 1)
        otf.AddPoint(lo, 1)
        otf.AddPoint(hi, 1)
    else:
        mapper.SetBlendModeToComposite()
        ctf.AddRGBPoint(0, 1, 0.9, 0.8)
        ctf.AddRGBPoint(2000, 1, 0.6, 0.5)
        otf.AddPoint(0, 0)
        otf.AddPoint(300, 0)
        otf.AddPoint(600, 0.2)
        otf.AddPoint(2000, 1)
        prop.SetScalarOpacityUnitDistance(step)
        prop.ShadeOn()
        prop.SetAmbient(0.2)
        prop.SetDiffuse(0.8)
        prop.SetSpecular(0.1)
        prop.SetSpecularPower(150)
    prop.SetColor(ctf)
    prop.SetScalarOpacity(otf)
    volume = vtk.vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)

    ren = vtk.vtkRenderer()
    ren.AddVolume(volume)
    ren.SetBackground(0, 0, 0)
    win = vtk.vtkRenderWindow()
    win.SetOffScreenRendering(1)
    win.AddRenderer(ren)
    win.SetSize(size, size)
    cam = ren.GetActiveCamera()
    cam.ParallelProjectionOn()
    cam.SetPosition(*fr)
    cam.SetFocalPoint(*at)
    cam.SetViewUp(*up)
    cam.SetParallelScale(130)
    dist = float(np.linalg.norm(np.subtract(fr, at)))
    cam.SetClippingRange(dist - 130, dist + 130)

    t = time.perf_counter()
    win.Render()
    first = time.perf_counter() - t
    later = float("inf")
    for _ in range(5):
        volume.Modified()
        t = time.perf_counter()
        win.Render()
        later = min(later, time.perf_counter() - t)
    if len(sys.argv) > 9:
        grab = vtk.vtkWindowToImageFilter()
        grab.SetInput(win)
        grab.Update()
        png = vtk.vtkPNGWriter()
        png.SetFileName(sys.argv[9])
        png.SetInputConnection(grab.GetOutputPort())
        png.Write()
    print(f"{first:.4f} {later:.4f}")


if __name__ == "__main__":
    main()
