"""Peer renderers for the benchmarks: VTK's ray casters on a pyvr scene.

The moderngl/GLSL reference lives with the tests (tests/reference/).
"""

import os

import numpy as np

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


class VtkPeer:
    """One VTK mapper on the same volume, transfer function and camera."""

    def __init__(self, kind, volume, lut, camera, light, size, reference_step):
        import vtk
        from vtk.util import numpy_support

        self.vtk = vtk
        data = np.asarray(volume.data, np.float32)
        lo, hi = np.asarray(volume.min_bounds, np.float64), np.asarray(volume.max_bounds, np.float64)
        spacing = (hi - lo) / np.array(data.shape)
        img = vtk.vtkImageData()
        img.SetDimensions(*data.shape)
        img.SetSpacing(*spacing)
        img.SetOrigin(*(lo + spacing / 2))
        img.GetPointData().SetScalars(numpy_support.numpy_to_vtk(data.ravel(order="F"), deep=True))
        ctf, otf = vtk.vtkColorTransferFunction(), vtk.vtkPiecewiseFunction()
        m = len(lut)
        for i in range(0, m, max(1, m // 128)):
            v = i / (m - 1)
            ctf.AddRGBPoint(v, *lut[i, :3])
            otf.AddPoint(v, float(lut[i, 3]))
        prop = vtk.vtkVolumeProperty()
        prop.SetColor(ctf)
        prop.SetScalarOpacity(otf)
        prop.SetScalarOpacityUnitDistance(reference_step)
        prop.SetInterpolationTypeToLinear()
        if light.diffuse_intensity > 0:
            prop.ShadeOn()
            prop.SetAmbient(light.ambient_intensity)
            prop.SetDiffuse(light.diffuse_intensity)
            prop.SetSpecular(0.0)
        self.mapper = (vtk.vtkFixedPointVolumeRayCastMapper if kind == "cpu" else vtk.vtkGPUVolumeRayCastMapper)()
        self.mapper.SetInputData(img)
        self.mapper.SetAutoAdjustSampleDistances(0)
        if kind == "cpu":
            self.mapper.SetImageSampleDistance(1.0)
        else:
            self.mapper.SetUseJittering(0)
        actor = vtk.vtkVolume()
        actor.SetMapper(self.mapper)
        actor.SetProperty(prop)
        ren = vtk.vtkRenderer()
        ren.AddVolume(actor)
        ren.SetBackground(0, 0, 0)
        cam = ren.GetActiveCamera()
        pos, up = camera.get_camera_vectors()
        cam.SetPosition(*np.asarray(pos, np.float64))
        cam.SetFocalPoint(*np.asarray(camera.target, np.float64))
        cam.SetViewUp(*np.asarray(up, np.float64))
        cam.SetViewAngle(np.degrees(camera.fov))
        ren.ResetCameraClippingRange()
        self.win = vtk.vtkRenderWindow()
        self.win.SetOffScreenRendering(1)
        self.win.AddRenderer(ren)
        self.win.SetSize(*size)
        self.grab = vtk.vtkWindowToImageFilter()
        self.grab.SetInput(self.win)
        self.grab.SetInputBufferTypeToRGB()
        self.grab.ReadFrontBufferOff()
        self.size = size

    def render(self, sample_distance):
        from vtk.util import numpy_support

        self.mapper.SetSampleDistance(sample_distance)
        self.win.Render()
        self.grab.Modified()
        self.grab.Update()
        rgb = numpy_support.vtk_to_numpy(self.grab.GetOutput().GetPointData().GetScalars())
        rgb = rgb.reshape(self.size[1], self.size[0], 3).astype(np.float64) / 255.0
        return np.concatenate([rgb, np.zeros(rgb.shape[:2] + (1,))], axis=-1)

    def release(self):
        self.win.Finalize()
