"""GLSL 3.30 sources of the renderer's programs (capsules/spheres, ground, shadows, overlays).

Shading works directly on the YAML's (sRGB) colours: no gamma conversions per pixel, which
keep software rasterisers (Mesa llvmpipe on machines with no GPU) fast.
"""

from __future__ import annotations

_LIGHTING = """
uniform vec3 u_light_dir;   // towards the light, unit
uniform vec3 u_eye;
uniform vec3 u_sky;         // sRGB clear colour, also the fog colour
uniform float u_fog_start;
uniform float u_fog_end;

float fog_amount(vec3 world) {
    return smoothstep(u_fog_start, u_fog_end, length(world - u_eye));
}

vec3 shade(vec3 albedo, vec3 n, vec3 world, float occlusion) {
    vec3 v = normalize(u_eye - world);
    float diffuse = max(dot(n, u_light_dir), 0.0);
    // Hemisphere ambient: sky from above, warm ground bounce from below.
    vec3 ambient = mix(vec3(0.42, 0.40, 0.37), vec3(0.62, 0.66, 0.72), n.y * 0.5 + 0.5);
    vec3 h = normalize(u_light_dir + v);
    float s = max(dot(n, h), 0.0);
    s *= s; s *= s; s *= s; s *= s;  // ^16
    float spec = s * 0.22 * step(0.0, diffuse);
    float r = 1.0 - max(dot(n, v), 0.0);
    float rim = r * r * r * 0.10;
    vec3 lit = albedo * (ambient * occlusion + vec3(1.0, 0.97, 0.92) * diffuse * 0.55) + spec + rim;
    return mix(lit, u_sky, fog_amount(world));
}
"""

SOLID_VERTEX = """
#version 330
uniform mat4 u_viewproj;
in vec3 in_local;     // point of the unit sphere
in float in_end;      // 0: hemisphere at A, 1: at B (the cylinder joins them)
in vec3 i_a;
in vec3 i_b;
in float i_radius;
in vec4 i_color;
out vec3 v_normal;
out vec3 v_world;
out vec4 v_color;
void main() {
    vec3 axis = i_b - i_a;
    float len = length(axis);
    vec3 w = len > 1e-6 ? axis / len : vec3(0.0, 1.0, 0.0);
    vec3 helper = abs(w.y) < 0.99 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
    vec3 u = normalize(cross(helper, w));
    vec3 v = cross(w, u);
    vec3 n = u * in_local.x + v * in_local.y + w * in_local.z;
    vec3 p = mix(i_a, i_b, in_end) + i_radius * n;
    v_normal = n;
    v_world = p;
    v_color = i_color;
    gl_Position = u_viewproj * vec4(p, 1.0);
}
"""

SOLID_FRAGMENT = (
    """
#version 330
in vec3 v_normal;
in vec3 v_world;
in vec4 v_color;
out vec4 f_color;
"""
    + _LIGHTING
    + """
void main() {
    vec3 n = normalize(v_normal);
    // Cheap contact occlusion: surfaces near the ground get less ambient light.
    float occlusion = mix(0.55, 1.0, smoothstep(0.0, 0.35, v_world.y));
    f_color = vec4(shade(v_color.rgb, n, v_world, occlusion), 1.0);
}
"""
)

GROUND_VERTEX = """
#version 330
uniform mat4 u_viewproj;
uniform vec2 u_center;
uniform float u_extent;
in vec2 in_pos;       // corners of [-1, 1]^2
out vec3 v_world;
void main() {
    vec3 p = vec3(u_center.x + in_pos.x * u_extent, 0.0, u_center.y + in_pos.y * u_extent);
    v_world = p;
    gl_Position = u_viewproj * vec4(p, 1.0);
}
"""

GROUND_FRAGMENT = (
    """
#version 330
uniform vec3 u_ground;      // already lit (the ground is flat: one colour)
in vec3 v_world;
out vec4 f_color;
"""
    + _LIGHTING
    + """
float grid(vec2 p, float spacing, float width) {
    vec2 q = p / spacing;
    vec2 d = abs(fract(q - 0.5) - 0.5) / max(fwidth(q), vec2(1e-5));
    return 1.0 - min(min(d.x, d.y) / width, 1.0);
}
void main() {
    vec2 p = v_world.xz;
    float dist = length(v_world - u_eye);
    float fade = 1.0 - smoothstep(u_fog_start * 0.5, u_fog_end * 0.8, dist);
    float minor = grid(p, 1.0, 1.0) * 0.18;
    float major = grid(p, 5.0, 1.5) * 0.32;
    vec3 albedo = u_ground * (1.0 - max(minor, major) * fade);
    // The world axes through the origin: x reddish, z bluish.
    float ax = (1.0 - min(abs(p.y) / max(fwidth(p.y), 1e-5) / 1.5, 1.0)) * fade;
    float az = (1.0 - min(abs(p.x) / max(fwidth(p.x), 1e-5) / 1.5, 1.0)) * fade;
    albedo = mix(albedo, vec3(0.75, 0.35, 0.3), ax * 0.6);
    albedo = mix(albedo, vec3(0.3, 0.4, 0.75), az * 0.6);
    f_color = vec4(mix(albedo, u_sky, fog_amount(v_world)), 1.0);
}
"""
)

SHADOW_VERTEX = """
#version 330
uniform mat4 u_viewproj;
in vec2 in_pos;       // corners of [-1, 1]^2
in vec3 i_a;
in vec3 i_b;
in float i_radius;
in vec4 i_color;      // rgb; a = strength. Ring instances have i_kind = 1.
in float i_kind;
out vec2 v_xz;
flat out vec3 v_a;
flat out vec3 v_b;
flat out float v_radius;
flat out vec4 v_color;
flat out float v_kind;
void main() {
    vec2 a = i_a.xz, b = i_b.xz;
    vec2 d = b - a;
    float len = length(d);
    vec2 dir = len > 1e-6 ? d / len : vec2(1.0, 0.0);
    vec2 perp = vec2(-dir.y, dir.x);
    float h = max(max(i_a.y, i_b.y) - i_radius, 0.0);
    float extent = i_kind > 0.5 ? i_radius * 1.3 : i_radius * (1.4 + 0.8 * h) + 0.4 * h + 0.02;
    vec2 mid = 0.5 * (a + b);
    vec2 p = mid + in_pos.x * (0.5 * len + extent) * dir + in_pos.y * extent * perp;
    v_xz = p;
    v_a = i_a; v_b = i_b; v_radius = i_radius; v_color = i_color; v_kind = i_kind;
    gl_Position = u_viewproj * vec4(p.x, 0.002, p.y, 1.0);
}
"""

SHADOW_FRAGMENT = """
#version 330
in vec2 v_xz;
flat in vec3 v_a;
flat in vec3 v_b;
flat in float v_radius;
flat in vec4 v_color;
flat in float v_kind;
out vec4 f_color;
void main() {
    vec2 a = v_a.xz, b = v_b.xz;
    vec2 ab = b - a;
    float t = clamp(dot(v_xz - a, ab) / max(dot(ab, ab), 1e-9), 0.0, 1.0);
    float dist = length(v_xz - (a + t * ab));
    float alpha;
    if (v_kind > 0.5) {
        // Selection ring of radius v_radius.
        float band = abs(dist - v_radius) / (0.06 * v_radius + 0.01);
        alpha = v_color.a * (1.0 - smoothstep(0.6, 1.0, band));
    } else {
        // Soft blob under the closest point of the capsule: it grows, blurs and fades with
        // the height of that point above the ground, so touching parts leave dark spots.
        float h = max(mix(v_a.y, v_b.y, t) - v_radius, 0.0);
        float r = v_radius * (1.0 + 0.5 * h);
        float soft = 0.35 * v_radius + 0.35 * h + 0.01;
        alpha = v_color.a * exp(-2.2 * h) * (1.0 - smoothstep(r - soft, r + soft, dist));
    }
    if (alpha < 0.003) discard;
    f_color = vec4(v_color.rgb, alpha);
}
"""

OVERLAY_VERTEX = """
#version 330
uniform vec4 u_rect;  // x0, y0, x1, y1 in clip space
in vec2 in_pos;       // corners of [0, 1]^2
out vec2 v_uv;
void main() {
    v_uv = vec2(in_pos.x, 1.0 - in_pos.y);
    gl_Position = vec4(mix(u_rect.xy, u_rect.zw, in_pos), 0.0, 1.0);
}
"""

OVERLAY_FRAGMENT = """
#version 330
uniform sampler2D u_texture;
in vec2 v_uv;
out vec4 f_color;
void main() {
    f_color = texture(u_texture, v_uv);
}
"""
