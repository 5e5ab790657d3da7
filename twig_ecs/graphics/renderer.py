"""The renderer: draws a Scene's store with moderngl, the same way on screen and offscreen.

Every frame reads node and link rows straight from :class:`~twig_ecs.store.PhysicsState`
(interpolated between the last two steps) and issues one instanced draw call per shape
kind: ground, contact shadows (+ selection ring), capsules (visible links and noses),
spheres (sphere nodes such as the ball, and eyes), then text panels. It draws into its own
multisampled framebuffer and resolves into ``Renderer.frame``, which the window blits to
the screen and offscreen output reads back: one drawing path for both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import moderngl
import numpy as np

from twig_ecs.graphics import shaders
from twig_ecs.graphics.camera import OrbitCamera
from twig_ecs.store import LINK_GRAB, LINK_VISIBLE, NODE_SPHERE

SKY = (0.70, 0.80, 0.90)
GROUND = (0.78, 0.77, 0.72)
LIGHT_DIR = np.array([0.45, 0.8, 0.35]) / np.linalg.norm([0.45, 0.8, 0.35])
FACE_NODES = ("head", "neck", "l_shoulder", "r_shoulder", "spine")
EYE_COLOR = (0.06, 0.06, 0.08, 1.0)
ATTENTION_COLOR = np.array((1.0, 0.85, 0.2, 1.0), dtype=np.float32)
HIDDEN_LINK_COLOR = (0.35, 0.35, 0.38, 1.0)
RING_COLOR = (1.0, 0.85, 0.1, 0.9)

#: Floats per instance of the solid and shadow programs: a(3) b(3) radius(1) color(4) [kind(1)].
SOLID_FLOATS = 11
#: Capsule instances beyond which the coarse capsule mesh is drawn (about 60 characters).
COARSE_ABOVE = 1000
SHADOW_FLOATS = 12


def ground_colour() -> tuple[float, float, float]:
    """The flat ground's lit colour: the solid shader's lighting for a normal straight up."""
    up = np.array([0.0, 1.0, 0.0])
    ambient = np.array([0.62, 0.66, 0.72])
    lit = np.array(GROUND) * (ambient + np.array([1.0, 0.97, 0.92]) * max(0.0, LIGHT_DIR @ up) * 0.55)
    return tuple(float(c) for c in np.clip(lit, 0.0, 1.0))


def capsule_mesh(segments: int = 16, half_rings: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """A unit sphere split at its equator into two hemispheres (end 0 and end 1).

    Returns (vertices (n, 4) float32: local xyz + end, indices uint32). The vertex shader
    moves the end-0 half to A and the end-1 half to B; the band between the duplicated
    equator rings becomes the cylinder.
    """
    rings = []
    for end, lats in ((0.0, np.linspace(-math.pi / 2, 0.0, half_rings + 1)),
                      (1.0, np.linspace(0.0, math.pi / 2, half_rings + 1))):  # fmt: skip
        for lat in lats:
            rings.append((end, lat))
    theta = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
    verts = []
    for end, lat in rings:
        c, s = math.cos(lat), math.sin(lat)
        for t in theta:
            verts.append((c * math.cos(t), c * math.sin(t), s, end))
    idx = []
    for r in range(len(rings) - 1):
        for k in range(segments):
            k2 = (k + 1) % segments
            a, b = r * segments + k, r * segments + k2
            c, d = a + segments, b + segments
            idx += [a, b, d, a, d, c]
    return np.array(verts, dtype=np.float32), np.array(idx, dtype=np.uint32)


@dataclass
class Faces:
    """Node rows of every humanoid head, for the eye and nose markers."""

    head: np.ndarray
    neck: np.ndarray
    l_shoulder: np.ndarray
    r_shoulder: np.ndarray
    spine: np.ndarray
    radius: np.ndarray  # head radius (m)
    color: np.ndarray  # (n, 4) nose colour

    @classmethod
    def empty(cls) -> Faces:
        z = np.zeros(0, dtype=np.int64)
        return cls(z, z, z, z, z, np.zeros(0), np.zeros((0, 4), dtype=np.float32))


@dataclass
class SceneTables:
    """Index tables derived from the store, rebuilt when ``state.version`` changes."""

    version: int
    visible_links: np.ndarray
    hidden_links: np.ndarray
    spheres: np.ndarray
    faces: Faces
    body_rows: dict[str, tuple[int, int]] = field(default_factory=dict)  # name -> node rows


def build_tables(scene) -> SceneTables:
    """Which links to draw, which nodes are spheres, where the heads are."""
    state = scene.state
    lk, n = state.links, state.nodes
    flags = lk.flags[: lk.count]
    visible = np.flatnonzero(flags & LINK_VISIBLE)
    hidden = np.flatnonzero((flags & LINK_VISIBLE) == 0)
    spheres = np.flatnonzero(n.flags[: n.count] & NODE_SPHERE)
    cols: dict[str, list] = {k: [] for k in (*FACE_NODES, "radius", "color")}
    rows: dict[str, tuple[int, int]] = {}
    for name in scene.entity_names:
        body = scene.entity(name).body
        rows[name] = (body.rows.start, body.rows.stop)
        if not all(k in body.node_names for k in FACE_NODES):
            continue
        idx = {k: body.node_index(k) for k in FACE_NODES}
        radius = 0.1 * body.height / 1.75
        for j in range(body.link_start, body.link_start + body.link_count):
            if {int(lk.a[j]), int(lk.b[j])} == {idx["head"], idx["neck"]} and lk.radius[j] > 0:
                radius = float(lk.radius[j])
        for k in FACE_NODES:
            cols[k].append(idx[k])
        cols["radius"].append(radius)
        head_color = n.color[idx["head"]].copy()
        head_color[:3] *= 0.72
        cols["color"].append(head_color)
    if cols["head"]:
        index = (np.array(cols[k], dtype=np.int64) for k in FACE_NODES)
        faces = Faces(*index, np.array(cols["radius"]), np.array(cols["color"], dtype=np.float32))
    else:
        faces = Faces.empty()
    return SceneTables(state.version, visible, hidden, spheres, faces, rows)


def _unit(v: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(norm, 1e-9)


def face_frames(pos: np.ndarray, faces: Faces, gaze: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """(forward, left, up) unit vectors of each head.

    Up runs from the neck to the head; forward is the torso's forward,
    cross(l_shoulder - r_shoulder, neck - spine), made perpendicular to up. ``gaze``, a
    per-face look direction (a character's head direction; NaN rows for other bodies),
    replaces the torso forward where given.
    """
    up = _unit(pos[faces.head] - pos[faces.neck])
    ahead = np.cross(pos[faces.l_shoulder] - pos[faces.r_shoulder], pos[faces.neck] - pos[faces.spine])
    if gaze is not None:
        given = np.isfinite(gaze).all(axis=1)
        ahead[given] = gaze[given]
    fwd = _unit(ahead - (ahead * up).sum(axis=1, keepdims=True) * up)
    left = np.cross(up, fwd)
    return fwd, left, up


def attention_lines(scene, pos: np.ndarray) -> np.ndarray:
    """Thin capsules from each perceiving character's head to its focus of attention."""

    from twig_ecs.components import Memory

    starts, ends = [], []
    for entity, memory in scene.world.get_component(Memory):
        if memory.focus is None or not scene.has_entity(memory.focus):
            continue
        me, it = scene.entity(scene.name_of(entity)), scene.entity(memory.focus)
        starts.append(pos[me.body.node_index("head")])
        target = it.body.node_index("head") if "head" in it.node_names else None
        ends.append(pos[target] if target is not None else it.position)
    if not starts:
        return np.zeros((0, SOLID_FLOATS), dtype=np.float32)
    count = len(starts)
    return solid_instances(np.array(starts), np.array(ends), np.full(count, 0.012),
                           np.tile(ATTENTION_COLOR, (count, 1)))  # fmt: skip


def solid_instances(a: np.ndarray, b: np.ndarray, radius: np.ndarray, color: np.ndarray) -> np.ndarray:
    """Pack instance rows (a, b, radius, colour) as float32 (n, 11)."""
    out = np.empty((len(a), SOLID_FLOATS), dtype=np.float32)
    out[:, 0:3], out[:, 3:6], out[:, 6], out[:, 7:11] = a, b, radius, color
    return out


class _Stream:
    """A growable instance buffer, re-filled every frame."""

    def __init__(self, ctx: moderngl.Context, floats: int) -> None:
        self.buffer = ctx.buffer(reserve=floats * 4 * 64, dynamic=True)
        self.count = 0

    def write(self, rows: np.ndarray) -> None:
        data = np.ascontiguousarray(rows, dtype=np.float32).tobytes()
        if len(data) > self.buffer.size:
            self.buffer.orphan(max(len(data), 2 * self.buffer.size))
        if data:
            self.buffer.write(data)
        self.count = len(rows)


@dataclass
class RenderOptions:
    """Toggles of what is drawn."""

    show_hidden_links: bool = False  # the invisible stiffeners and grab joints, thin and grey
    shadows: bool = True
    faces: bool = True
    selected: str | None = None  # entity name with a ring on the ground under it
    attention: bool = False  # a thin yellow line from each perceiving head to its focus
    #: more capsule rows (``solid_instances``) to draw this frame: the window's mouse spring
    extra_capsules: np.ndarray | None = None


class Renderer:
    """Draws scenes into a multisampled framebuffer; ``frame`` holds the resolved image."""

    def __init__(self, ctx: moderngl.Context, samples: int = 4) -> None:
        self.ctx = ctx
        self.samples = min(samples, ctx.max_samples) if samples > 1 else 0
        self.options = RenderOptions()
        self._tables: SceneTables | None = None
        self._tables_key: tuple[int, int] | None = None
        self.size: tuple[int, int] = (0, 0)
        self.frame: moderngl.Framebuffer | None = None  # resolved colour, read this
        self._draw_fbo: moderngl.Framebuffer | None = None
        #: the last scene drawn with ``keep_scene``, without its panels (made on the first such frame)
        self._scene_copy: moderngl.Framebuffer | None = None
        self._targets: list = []

        program = ctx.program
        self.solid = program(vertex_shader=shaders.SOLID_VERTEX, fragment_shader=shaders.SOLID_FRAGMENT)
        self.ground = program(vertex_shader=shaders.GROUND_VERTEX, fragment_shader=shaders.GROUND_FRAGMENT)
        self.shadow = program(vertex_shader=shaders.SHADOW_VERTEX, fragment_shader=shaders.SHADOW_FRAGMENT)
        self.overlay = program(vertex_shader=shaders.OVERLAY_VERTEX, fragment_shader=shaders.OVERLAY_FRAGMENT)
        quad = ctx.buffer(np.array([-1, -1, 1, -1, -1, 1, 1, 1], dtype=np.float32).tobytes())
        unit_quad = ctx.buffer(np.array([0, 0, 1, 0, 0, 1, 1, 1], dtype=np.float32).tobytes())

        self.capsules = _Stream(ctx, SOLID_FLOATS)
        self.spheres = _Stream(ctx, SOLID_FLOATS)
        self.shadows = _Stream(ctx, SHADOW_FLOATS)
        inst = (SOLID_FLOATS, "3f 3f 1f 4f/i", "i_a", "i_b", "i_radius", "i_color")
        self._capsule_vao = self._solid_vao(*capsule_mesh(12, 3), self.capsules.buffer, inst)
        # a crowd's many small capsules: a coarser mesh halves the triangles (a software
        # rasteriser draws 300 characters at ~13 frames/s with the fine one, ~25 with this)
        self._coarse_capsule_vao = self._solid_vao(*capsule_mesh(8, 2), self.capsules.buffer, inst)
        self._sphere_vao = self._solid_vao(*capsule_mesh(20, 6), self.spheres.buffer, inst)
        self._ground_vao = ctx.vertex_array(self.ground, [(quad, "2f", "in_pos")])
        self._shadow_vao = ctx.vertex_array(
            self.shadow,
            [(quad, "2f", "in_pos"),
             (self.shadows.buffer, "3f 3f 1f 4f 1f/i", "i_a", "i_b", "i_radius", "i_color", "i_kind")],
        )  # fmt: skip
        self._overlay_vao = ctx.vertex_array(self.overlay, [(unit_quad, "2f", "in_pos")])
        self._panel_textures: dict[str, tuple[object, moderngl.Texture]] = {}

    def _solid_vao(self, verts, idx, inst_buffer, inst) -> moderngl.VertexArray:
        vbo = self.ctx.buffer(verts.tobytes())
        ibo = self.ctx.buffer(idx.tobytes())
        _floats, fmt, *names = inst
        return self.ctx.vertex_array(
            self.solid, [(vbo, "3f 1f", "in_local", "in_end"), (inst_buffer, fmt, *names)], index_buffer=ibo
        )

    # -- targets ------------------------------------------------------------------------

    def resize(self, size: tuple[int, int]) -> None:
        """(Re)create the framebuffers for a ``(width, height)`` image in pixels."""
        size = (max(1, int(size[0])), max(1, int(size[1])))
        if size == self.size and self.frame is not None:
            return
        for obj in self._targets:
            obj.release()
        self._scene_copy = None
        ctx = self.ctx
        color = ctx.texture(size, 4)
        self.frame_texture = color
        self.frame = ctx.framebuffer(color_attachments=[color])
        self._targets = [self.frame, color]
        if self.samples:
            ms_color = ctx.renderbuffer(size, 4, samples=self.samples)
            ms_depth = ctx.depth_renderbuffer(size, samples=self.samples)
            self._draw_fbo = ctx.framebuffer(color_attachments=[ms_color], depth_attachment=ms_depth)
            self._targets += [self._draw_fbo, ms_color, ms_depth]
        else:
            depth = ctx.depth_renderbuffer(size)
            self.frame.release()
            self.frame = ctx.framebuffer(color_attachments=[color], depth_attachment=depth)
            self._draw_fbo = self.frame
            self._targets = [self.frame, color, depth]
        self.size = size

    def tables(self, scene) -> SceneTables:
        """Index tables of ``scene``, cached per scene and store version."""
        key = (id(scene.state), scene.state.version)
        if self._tables is None or self._tables_key != key:
            self._tables = build_tables(scene)
            self._tables_key = key
        return self._tables

    # -- drawing --------------------------------------------------------------------

    def render(self, scene, camera: OrbitCamera, size: tuple[int, int], alpha: float = 1.0,
               panels: tuple = (), keep_scene: bool = False) -> moderngl.Framebuffer:  # fmt: skip
        """Draw ``scene`` seen by ``camera`` into ``self.frame`` and return it.

        ``alpha`` in [0, 1] interpolates node positions between the previous and the
        current step. ``panels`` are (key, PIL RGBA image, x, y) text panels placed in
        pixels from the top-left corner. ``scene`` None draws the last scene again (another
        thread is stepping it) under new ``panels``: the pixels kept by the last frame drawn
        with ``keep_scene`` at this size (a copy, where a software rasteriser takes 0.1-0.4 s
        to draw it), else its shapes.
        """
        self.resize(size)
        ctx = self.ctx
        width, height = self.size
        if scene is None and self._scene_copy is not None:
            ctx.copy_framebuffer(self.frame, self._scene_copy)
            self.frame.use()
            ctx.viewport = (0, 0, width, height)
            self._draw_panels(panels)
            return self.frame
        fbo = self._draw_fbo
        fbo.use()
        ctx.viewport = (0, 0, width, height)
        ctx.clear(*SKY, 1.0, depth=1.0)
        if scene is not None:
            self._fill(scene, alpha)

        viewproj = camera.view_projection(width / height).astype(np.float32)
        eye = camera.eye
        fog_end = max(60.0, camera.distance * 6.0)
        uniforms = {"u_light_dir": tuple(LIGHT_DIR), "u_eye": tuple(eye), "u_sky": SKY,
                    "u_fog_start": fog_end * 0.35, "u_fog_end": fog_end}  # fmt: skip
        for prog in (self.solid, self.ground):
            prog["u_viewproj"].write(viewproj.T.tobytes())
            for name, value in uniforms.items():
                if name in prog:  # the compiler drops uniforms a program does not use
                    prog[name].value = value
        self.shadow["u_viewproj"].write(viewproj.T.tobytes())
        self.ground["u_center"].value = (float(camera.target[0]), float(camera.target[2]))
        self.ground["u_extent"].value = fog_end * 1.2
        self.ground["u_ground"].value = ground_colour()

        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.BLEND | moderngl.CULL_FACE)
        self._ground_vao.render(moderngl.TRIANGLE_STRIP)
        if self.shadows.count:
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
            ctx.disable(moderngl.DEPTH_TEST)  # they lie on the ground, drawn before all solids
            self._shadow_vao.render(moderngl.TRIANGLE_STRIP, instances=self.shadows.count)
            ctx.enable(moderngl.DEPTH_TEST)
            ctx.disable(moderngl.BLEND)
        if self.capsules.count:
            crowded = self.capsules.count > COARSE_ABOVE
            vao = self._coarse_capsule_vao if crowded else self._capsule_vao
            vao.render(moderngl.TRIANGLES, instances=self.capsules.count)
        if self.spheres.count:
            self._sphere_vao.render(moderngl.TRIANGLES, instances=self.spheres.count)
        if keep_scene:
            if self._scene_copy is None:
                color = ctx.texture(self.size, 4)
                self._scene_copy = ctx.framebuffer(color_attachments=[color])
                self._targets += [self._scene_copy, color]
            ctx.copy_framebuffer(self._scene_copy, fbo)
            fbo.use()
        self._draw_panels(panels)
        if fbo is not self.frame:
            ctx.copy_framebuffer(self.frame, fbo)
        return self.frame

    def render_panels(self, size: tuple[int, int], panels: tuple) -> moderngl.Framebuffer:
        """Draw only text ``panels`` on the sky colour (a window with no scene yet)."""
        self.resize(size)
        fbo = self._draw_fbo
        fbo.use()
        self.ctx.viewport = (0, 0, *self.size)
        self.ctx.clear(*SKY, 1.0, depth=1.0)
        self._draw_panels(panels)
        if fbo is not self.frame:
            self.ctx.copy_framebuffer(self.frame, fbo)
        return self.frame

    def _fill(self, scene, alpha: float) -> None:
        """Gather this frame's instances from the store into the instance buffers."""
        state = scene.state
        t = self.tables(scene)
        n, lk = state.nodes, state.links
        cur, prev = n.pos[: n.count], n.prev[: n.count]
        pos = prev + alpha * (cur - prev) if alpha < 1.0 else cur
        opts = self.options

        links = t.visible_links
        caps = [solid_instances(pos[lk.a[links]], pos[lk.b[links]], lk.radius[links], lk.color[links])]
        if opts.show_hidden_links and len(t.hidden_links):
            h = t.hidden_links
            color = np.where((lk.flags[h] & LINK_GRAB)[:, None] != 0, (0.9, 0.2, 0.9, 1.0), HIDDEN_LINK_COLOR)
            caps.append(solid_instances(pos[lk.a[h]], pos[lk.b[h]], np.full(len(h), 0.008), color))
        sph = t.spheres
        balls = [solid_instances(pos[sph], pos[sph], n.radius[sph], n.color[sph])]
        if opts.attention:
            caps.append(attention_lines(scene, pos))
        if opts.extra_capsules is not None and len(opts.extra_capsules):
            caps.append(np.asarray(opts.extra_capsules, dtype=np.float32))

        faces = t.faces
        if opts.faces and len(faces.head):
            face_gaze = None
            ch = state.characters
            if ch.count:  # characters' faces point where their gaze controller turned them
                gaze = np.full((state.bodies.count, 3), np.nan)
                gaze[ch.body[: ch.count]] = ch.face_dir[: ch.count]  # (with an idle glance)
                face_gaze = gaze[n.body[faces.head]]
            fwd, left, up = face_frames(pos, faces, face_gaze)
            r = faces.radius[:, None]
            centre = pos[faces.head]
            # Nose: a short capsule straight ahead; eyes: two dark dots above it (capsules
            # with both ends at one point: small, so the coarser capsule mesh will do).
            caps.append(solid_instances(centre + 0.55 * r * fwd, centre + 1.22 * r * fwd - 0.12 * r * up,
                                        0.2 * faces.radius, faces.color))  # fmt: skip
            for side in (1.0, -1.0):
                eye = centre + r * (0.8 * fwd + 0.36 * side * left + 0.22 * up)
                dark = np.tile(EYE_COLOR, (len(eye), 1))
                caps.append(solid_instances(eye, eye, 0.17 * faces.radius, dark))
        capsule_rows = np.concatenate(caps)  # visible links first: they cast the shadows
        self.capsules.write(capsule_rows)
        sphere_rows = np.concatenate(balls)
        self.spheres.write(sphere_rows)

        shadows = []
        if opts.shadows:
            casters = np.concatenate([capsule_rows[: len(links)], sphere_rows[: len(sph)]])
            rows = np.zeros((len(casters), SHADOW_FLOATS), dtype=np.float32)
            rows[:, :7] = casters[:, :7]
            rows[:, 10] = 0.55  # black, this strong where it touches
            shadows.append(rows)
        if opts.selected and opts.selected in t.body_rows:
            lo, hi = t.body_rows[opts.selected]
            centre = pos[lo:hi].mean(axis=0)
            extent = np.linalg.norm((pos[lo:hi] - centre)[:, [0, 2]], axis=1).max()
            ring = np.zeros((1, SHADOW_FLOATS), dtype=np.float32)
            ring[0, 0:3] = ring[0, 3:6] = (centre[0], 0.0, centre[2])
            ring[0, 6] = max(0.35, extent + 0.15)
            ring[0, 7:11] = RING_COLOR
            ring[0, 11] = 1.0
            shadows.append(ring)
        self.shadows.write(np.concatenate(shadows) if shadows else np.zeros((0, SHADOW_FLOATS)))

    def _draw_panels(self, panels) -> None:
        if not panels:
            return
        ctx = self.ctx
        width, height = self.size
        ctx.disable(moderngl.DEPTH_TEST)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        for key, image, x, y in panels:
            tex = self._panel_texture(key, image)
            w, h = image.size
            x0, x1 = 2 * x / width - 1, 2 * (x + w) / width - 1
            y0, y1 = 1 - 2 * (y + h) / height, 1 - 2 * y / height
            self.overlay["u_rect"].value = (x0, y0, x1, y1)
            tex.use(0)
            self._overlay_vao.render(moderngl.TRIANGLE_STRIP)
        ctx.disable(moderngl.BLEND)
        ctx.enable(moderngl.DEPTH_TEST)

    def _panel_texture(self, key: str, image) -> moderngl.Texture:
        """The texture of a panel, uploaded again only when the image object changes."""
        cached = self._panel_textures.get(key)
        if cached and cached[0] is image:
            return cached[1]
        if cached and cached[1].size == image.size:
            tex = cached[1]
            tex.write(image.tobytes())
        else:
            if cached:
                cached[1].release()
            tex = self.ctx.texture(image.size, 4, image.tobytes())
            tex.filter = moderngl.NEAREST, moderngl.NEAREST
        self._panel_textures[key] = (image, tex)
        return tex

    def present(self, screen: moderngl.Framebuffer, size: tuple[int, int]) -> None:
        """Copy the last frame onto ``screen`` (a window's framebuffer of ``size`` pixels)."""
        ctx = self.ctx
        screen.use()
        ctx.viewport = (0, 0, int(size[0]), int(size[1]))
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        self.overlay["u_rect"].value = (-1.0, 1.0, 1.0, -1.0)  # GL rows run bottom-up: no flip
        self.frame_texture.use(0)
        self._overlay_vao.render(moderngl.TRIANGLE_STRIP)

    # -- reading ----------------------------------------------------------------------

    def read_pixels(self) -> np.ndarray:
        """The last rendered frame as an (height, width, 3) uint8 array, top row first."""
        assert self.frame is not None, "render() first"
        width, height = self.size
        data = self.frame.read(components=3, alignment=1)
        return np.frombuffer(data, dtype=np.uint8).reshape(height, width, 3)[::-1].copy()

    def release(self) -> None:
        """Free GPU objects of this renderer (not the context)."""
        for obj in self._targets:
            obj.release()
        self._targets = []
        for _key, tex in self._panel_textures.values():
            tex.release()
        self._panel_textures.clear()
        self.frame = None
