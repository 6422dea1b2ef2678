// Flockway's scene shader: lit static geometry and instanced vehicles.

struct Camera {
    view_proj: mat4x4<f32>,
    // xyz: unit direction towards the sun.
    sun: vec4<f32>,
};

@group(0) @binding(0) var<uniform> camera: Camera;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) colour: vec4<f32>,
};

@vertex
fn vs_static(
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec4<f32>,
) -> VsOut {
    var out: VsOut;
    out.clip = camera.view_proj * vec4<f32>(position, 1.0);
    out.normal = normal;
    out.colour = colour;
    return out;
}

fn rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}

@vertex
fn vs_vehicle(
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) shade: f32,
    @location(3) translation: vec3<f32>,
    @location(4) rotation: vec4<f32>,
    @location(5) size: vec3<f32>,
    @location(6) colour: vec4<f32>,
) -> VsOut {
    var out: VsOut;
    let world = translation + rotate(rotation, position * size);
    out.clip = camera.view_proj * vec4<f32>(world, 1.0);
    out.normal = rotate(rotation, normal);
    out.colour = vec4<f32>(colour.rgb * shade, colour.a);
    return out;
}

@fragment
fn fs_main(in: VsOut) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    let diffuse = max(dot(n, camera.sun.xyz), 0.0);
    // Sky light from above plus the sun.
    let ambient = 0.45 + 0.15 * n.z;
    return vec4<f32>(in.colour.rgb * (ambient + 0.75 * diffuse), in.colour.a);
}
