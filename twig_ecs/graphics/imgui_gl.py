"""Dear ImGui's draw lists drawn with moderngl (the window's own OpenGL context).

imgui-bundle ships renderers written for PyOpenGL; the window already talks to OpenGL
through moderngl, so this small renderer draws ImGui's output with it instead (one
vertex array, a scissor per command) and keeps ImGui's textures (the font atlas, grown
on demand since ImGui 1.92) as moderngl textures whose GL names are ImGui's texture ids.
"""

from __future__ import annotations

import ctypes

import moderngl
import numpy as np

_VERTEX = """
#version 330
uniform vec2 u_display;
in vec2 in_pos;
in vec2 in_uv;
in vec4 in_color;
out vec2 v_uv;
out vec4 v_color;
void main() {
    v_uv = in_uv;
    v_color = in_color;
    gl_Position = vec4(2.0 * in_pos.x / u_display.x - 1.0, 1.0 - 2.0 * in_pos.y / u_display.y, 0.0, 1.0);
}
"""
_FRAGMENT = """
#version 330
uniform sampler2D u_texture;
in vec2 v_uv;
in vec4 v_color;
out vec4 f_color;
void main() { f_color = v_color * texture(u_texture, v_uv); }
"""


class ImguiRenderer:
    """Draws ``imgui.get_draw_data()`` into a moderngl framebuffer."""

    def __init__(self, ctx: moderngl.Context, imgui) -> None:
        self.ctx, self.imgui = ctx, imgui
        io = imgui.get_io()
        io.backend_flags |= imgui.BackendFlags_.renderer_has_textures
        platform = imgui.get_platform_io()
        size = ctx.info["GL_MAX_TEXTURE_SIZE"]
        platform.renderer_texture_max_width = platform.renderer_texture_max_height = size
        self.program = ctx.program(vertex_shader=_VERTEX, fragment_shader=_FRAGMENT)
        self.vbo = ctx.buffer(reserve=1 << 16, dynamic=True)
        self.ibo = ctx.buffer(reserve=1 << 16, dynamic=True)
        layout = (imgui.VERTEX_BUFFER_POS_OFFSET, imgui.VERTEX_BUFFER_UV_OFFSET,
                  imgui.VERTEX_BUFFER_COL_OFFSET, imgui.VERTEX_SIZE)  # fmt: skip
        if layout != (0, 8, 16, 20):  # the "2f 2f 4f1" format below
            raise RuntimeError(f"unexpected ImGui vertex layout {layout}")
        self.vao = ctx.vertex_array(self.program, [(self.vbo, "2f 2f 4f1", "in_pos", "in_uv", "in_color")],
                                    index_buffer=self.ibo, index_element_size=imgui.INDEX_SIZE)  # fmt: skip
        self.textures: dict[int, moderngl.Texture] = {}

    def _update_textures(self) -> None:
        """Create, update or drop the textures ImGui asks for (its RendererHasTextures protocol)."""
        imgui = self.imgui
        status = imgui.ImTextureStatus
        for tex in imgui.get_platform_io().textures:
            if tex.status == status.want_create or tex.status == status.want_updates:
                pixels = np.asarray(tex.get_pixels_array(), dtype=np.uint8)
                old = self.textures.get(tex.tex_id) if tex.status == status.want_updates else None
                texture = old or self.ctx.texture((tex.width, tex.height), 4)
                texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
                texture.repeat_x = texture.repeat_y = False
                texture.write(pixels.tobytes())  # the whole atlas: a few hundred kB, rarely
                self.textures[texture.glo] = texture
                tex.set_tex_id(texture.glo)
                tex.status = status.ok
            elif tex.status == status.want_destroy:
                texture = self.textures.pop(tex.tex_id, None)
                if texture is not None:
                    texture.release()
                tex.set_tex_id(0)
                tex.status = status.destroyed

    def render(self, draw_data, framebuffer: moderngl.Framebuffer, size: tuple[int, int]) -> None:
        """Draw ImGui's frame over what ``framebuffer`` holds (``size``: its pixels)."""
        self._update_textures()
        width, height = size
        if width <= 0 or height <= 0 or draw_data.cmd_lists_count == 0:
            return
        ctx = self.ctx
        framebuffer.use()
        ctx.viewport = (0, 0, width, height)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        display = draw_data.display_size
        self.program["u_display"].value = (float(display.x), float(display.y))
        sx, sy = width / max(display.x, 1.0), height / max(display.y, 1.0)
        origin = draw_data.display_pos
        imgui = self.imgui
        try:
            for commands in draw_data.cmd_lists:
                vertices = commands.vtx_buffer.size() * imgui.VERTEX_SIZE
                indices = commands.idx_buffer.size() * imgui.INDEX_SIZE
                self._upload(self.vbo, commands.vtx_buffer.data_address(), vertices)
                self._upload(self.ibo, commands.idx_buffer.data_address(), indices)
                for command in commands.cmd_buffer:
                    x0, y0, x1, y1 = command.clip_rect
                    x0, x1 = (x0 - origin.x) * sx, (x1 - origin.x) * sx
                    y0, y1 = (y0 - origin.y) * sy, (y1 - origin.y) * sy
                    if x1 <= x0 or y1 <= y0:
                        continue
                    ctx.scissor = (int(x0), int(height - y1), int(x1 - x0), int(y1 - y0))
                    texture = self.textures.get(command.tex_ref.get_tex_id())
                    if texture is None:
                        continue
                    texture.use(0)
                    self.vao.render(moderngl.TRIANGLES, vertices=command.elem_count, first=command.idx_offset)
        finally:
            ctx.scissor = None
            ctx.disable(moderngl.BLEND)

    @staticmethod
    def _upload(buffer: moderngl.Buffer, address: int, size: int) -> None:
        if size > buffer.size:
            buffer.orphan(max(size, 2 * buffer.size))
        if size:
            buffer.write(ctypes.string_at(address, size))

    def release(self) -> None:
        """Free the GPU objects (ImGui's own texture records are the ImGui context's)."""
        for texture in self.textures.values():
            texture.release()
        self.textures.clear()
        for obj in (self.vao, self.vbo, self.ibo, self.program):
            obj.release()
