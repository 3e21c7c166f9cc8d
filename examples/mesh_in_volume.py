"""
A mesh inside the volume
========================

An opaque mesh drawn by a real rasteriser (OpenGL through moderngl,
offscreen) inside a volume that pyvr renders around it: the rasteriser's
colour and depth buffers go to ``render(depth=, color=)``, the depth first
converted by ``pyvr.scene_depth.from_depth_buffer`` into distances along
pyvr's rays. Each ray stops at the mesh, and the volume in front of it is
composited over it; beside it, the same volume with the mesh pasted on top
(no depth), which hides the volume in front. Writes out/mesh_in_volume.png.

Needs an OpenGL driver (EGL; Mesa's llvmpipe will do) and
``pip install 'pyvr-rs[mesh]'`` (moderngl).

Run: .venv/bin/python examples/mesh_in_volume.py
"""

import numpy as np

from _common import out_path, save_grid
from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.datasets import create_sample_volume
from pyvr.lighting import Light
from pyvr.scene_depth import from_depth_buffer
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

SIZE = 320

VERTEX = """
#version 330
uniform mat4 view;
uniform mat4 proj;
in vec3 position;
in vec3 normal;
out vec3 n;
void main() {
    n = normal;
    gl_Position = proj * view * vec4(position, 1.0);
}
"""

FRAGMENT = """
#version 330
in vec3 n;
out vec4 colour;
void main() {
    float lit = 0.35 + 0.65 * max(dot(normalize(n), normalize(vec3(0.6, 0.3, 0.75))), 0.0);
    colour = vec4(vec3(0.95, 0.55, 0.2) * lit, 1.0);
}
"""


def torus(major=0.45, minor=0.14, n=96, m=32):
    """A torus about the z axis: vertices, normals and triangle indices."""
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, n, endpoint=False), np.linspace(0, 2 * np.pi, m, endpoint=False),
                       indexing="ij")
    centre = np.stack([major * np.cos(u), major * np.sin(u), np.zeros_like(u)], -1)
    normal = np.stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)], -1)
    points = centre + minor * normal
    i, j = np.meshgrid(np.arange(n), np.arange(m), indexing="ij")
    a, b = i * m + j, ((i + 1) % n) * m + j
    c, d = ((i + 1) % n) * m + (j + 1) % m, i * m + (j + 1) % m
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return points.reshape(-1, 3), normal.reshape(-1, 3), faces


def rasterise(camera: Camera, size: int):
    """The torus drawn with the camera's own matrices: colour (H, W, 3) in
    [0, 1] and window depth (H, W), row 0 at the bottom, as OpenGL reads."""
    try:
        import moderngl
    except ImportError:
        raise SystemExit("this example draws its mesh with moderngl: pip install 'pyvr-rs[mesh]'") from None
    try:
        ctx = moderngl.create_context(standalone=True, backend="egl")
    except Exception as e:  # no OpenGL driver: say so instead of a traceback
        raise SystemExit(f"no OpenGL context for the mesh ({e}); install Mesa's EGL (libegl1-mesa)") from None
    points, normals, faces = torus()
    program = ctx.program(vertex_shader=VERTEX, fragment_shader=FRAGMENT)
    # pyvr's view matrix is stored column-major already; its projection is not.
    program["view"].write(camera.get_view_matrix().astype("f4").tobytes())
    program["proj"].write(camera.get_projection_matrix(1.0).T.astype("f4").tobytes())
    vbo = ctx.buffer(np.hstack([points, normals]).astype("f4").tobytes())
    ibo = ctx.buffer(faces.astype("i4").tobytes())
    vao = ctx.vertex_array(program, [(vbo, "3f 3f", "position", "normal")], ibo)
    fbo = ctx.framebuffer(ctx.renderbuffer((size, size), 4, dtype="f4"), ctx.depth_renderbuffer((size, size)))
    fbo.use()
    fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
    ctx.enable(moderngl.DEPTH_TEST)
    vao.render()
    colour = np.frombuffer(fbo.read(components=3, dtype="f4"), "f4").reshape(size, size, 3)
    depth = np.frombuffer(fbo.read(components=1, attachment=-1, dtype="f4"), "f4").reshape(size, size)
    ctx.release()
    return np.clip(colour, 0.0, 1.0), depth


def main():
    data = create_sample_volume(96, "double_sphere")
    volume = Volume(data, min_bounds=np.full(3, -1, np.float32), max_bounds=np.full(3, 1, np.float32))
    camera = Camera.from_spherical(target=np.zeros(3, np.float32), azimuth=0.6, elevation=0.5, roll=0.0,
                                   distance=2.4)
    renderer = VolumeRenderer(SIZE, SIZE, config=RenderConfig.balanced(), light=Light.ambient_only(1.0))
    renderer.load_volume(volume)
    renderer.set_camera(camera)
    renderer.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"),
                                    OpacityTransferFunction.linear(0.0, 0.08))
    colour, window_depth = rasterise(camera, SIZE)
    depth = from_depth_buffer(window_depth, camera, camera.near_plane, camera.far_plane)
    around = renderer.render(depth=depth, color=colour)
    on_top = renderer.render()
    mesh = np.isfinite(depth)
    pasted = on_top.copy()
    pasted[mesh, :3] = np.round(colour[mesh] * 255)
    pasted[mesh, 3] = 255
    path = save_grid([around, pasted], ["mesh inside the volume (depth)", "mesh pasted on top"],
                     out_path("mesh_in_volume.png"), cols=2)
    print(f"mesh covers {mesh.mean():.0%} of the view; wrote {path}")


if __name__ == "__main__":
    main()
