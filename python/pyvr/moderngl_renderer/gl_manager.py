"""What ``VolumeRenderer.gl_manager`` is now. Kept for compatibility only.

In pyvr 0.4.1 ``renderer.gl_manager`` was the ``ModernGLManager`` that
owned the OpenGL context, its textures and shader uniforms, and
``renderer.gl_manager.cleanup()`` was the one way to release them. pyvr
renders with wgpu now and has no OpenGL context, so the attribute is a
stand-in: ``cleanup()`` is accepted (the renderer's device resources are
released when the renderer is garbage collected), ``width``/``height``
are the renderer's. The OpenGL calls (textures, uniforms, framebuffers)
have no counterpart: the renderer never calls them.
"""


class GLManagerStandIn:
    """``renderer.gl_manager`` for code written against pyvr 0.4.1."""

    def __init__(self, width: int, height: int):
        self.width = width
        self.height = height

    def cleanup(self) -> None:
        """Nothing to release by hand: the renderer frees its resources
        when it is garbage collected."""

    def __repr__(self) -> str:
        return f"GLManagerStandIn({self.width}x{self.height}, no OpenGL context)"
