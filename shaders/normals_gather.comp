#version 430 core
// Normals gather job, the second half of the normals (docs/inputs.md "Network evaluation"): per vertex i
//     normals[i] = normalize(sum of face_normals[f] over the faces f of vertex i)
// in the order of the CSR adjacency (asset sections NADO/NADF, ascending face order), so the sum has a fixed order
// and needs no atomics. The same function as sdk/src/normals.c plNormalsGatherJob and
// tools/pleat/reference/normals.py normals_gather; a zero sum gives a zero normal.

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

layout(std430, binding = 9) restrict readonly buffer AdjacencyOffsets { uint adjacency_offsets[]; }; // [N + 1]
layout(std430, binding = 10) restrict readonly buffer AdjacencyFaces { uint adjacency_faces[]; };    // [3F]
layout(std430, binding = 11) restrict writeonly buffer Normals { vec4 normals[]; };                  // [N] xyz, w = 0
layout(std430, binding = 12) restrict readonly buffer FaceNormals { vec4 face_normals[]; };          // [F]

void main()
{
	uint i = gl_GlobalInvocationID.x;
	if (i >= vertex_count)
		return;
	uint instance = gl_WorkGroupID.y;
	uint f0 = instance * face_count;
	vec3 n = vec3(0.0);
	uint end = adjacency_offsets[i + 1u];
	for (uint e = adjacency_offsets[i]; e < end; ++e)
		n += face_normals[f0 + adjacency_faces[e]].xyz;
	float length_sq = dot(n, n);
	normals[instance * vertex_count + i] = vec4(length_sq > 0.0 ? n * inversesqrt(length_sq) : vec3(0.0), 0.0);
}
