#version 430 core
// Face normals job, the first half of the normals (docs/inputs.md "Network evaluation"): per face f = (a, b, c)
//     face_normals[f] = (cross(x_b - x_a, x_c - x_a), 0)        unnormalised, so its length weighs by area
// The same function as sdk/src/normals.c plFaceNormalsJob and tools/pleat/reference/normals.py face_normals. One
// invocation per face; normals_gather.comp sums them per vertex after a barrier.

// Batches (plStepInstances, sdk/src/gl/gl_deformer.c plGlDeformer_RunBatch): gl_WorkGroupID.y is the instance, and
// every per-instance buffer holds one block per instance at that index; a single instance is instance 0.
layout(local_size_x = 64) in;

// C twin: plGlDeformParams (sdk/src/gl/gl_types.h).
layout(std140, binding = 0) uniform plGlDeformParams
{
	uint vertex_count;    // N
	uint blend_count;     // D
	uint influence_count; // K
	uint joint_count;     // J
	uint face_count;      // F
	uint anchor_influence_count; // Ka (body_contact.comp)
	float body_contact_offset_m; // (body_contact.comp)
};

layout(std430, binding = 7) restrict readonly buffer Positions { vec4 positions[]; };             // [N]
layout(std430, binding = 8) restrict readonly buffer Faces { uint faces[]; };                     // [F][3]
layout(std430, binding = 12) restrict writeonly buffer FaceNormals { vec4 face_normals[]; };      // [F] xyz, w = 0

void main()
{
	uint f = gl_GlobalInvocationID.x;
	if (f >= face_count)
		return;
	uint instance = gl_WorkGroupID.y;
	uint p = instance * vertex_count;
	vec3 a = positions[p + faces[3u * f]].xyz;
	vec3 b = positions[p + faces[3u * f + 1u]].xyz;
	vec3 c = positions[p + faces[3u * f + 2u]].xyz;
	face_normals[instance * face_count + f] = vec4(cross(b - a, c - a), 0.0);
}
