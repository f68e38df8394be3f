#version 430 core
// Skinning job, linear blend skinning with K sparse influences (docs/inputs.md "Network evaluation"):
//     positions[i] = (sum_k skin_weights[i][k] * M_{skin_indices[i][k]}) * (deformed[i], 1)
// Same loop as sdk/src/skinning.c and tools/pleat/reference/skinning.py: blend the K joints' 3x4 matrices with the
// skin weights in order k = 0 .. K-1, then transform the vertex once. One invocation per vertex.
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

layout(std430, binding = 3) restrict readonly buffer Deformed { vec4 deformed[]; };         // [instances][N] T_def
layout(std430, binding = 4) restrict readonly buffer SkinIndices { uint skin_indices[]; };  // [N][K] (u16 widened)
layout(std430, binding = 5) restrict readonly buffer SkinWeights { float skin_weights[]; }; // [N][K]
// [J][3] rows of the row-major 3x4 rest -> output matrix: row r = (M[r][0], M[r][1], M[r][2], M[r][3]).
layout(std430, binding = 6) restrict readonly buffer SkinMatrices { vec4 skin_matrices[]; }; // [instances][J][3]
layout(std430, binding = 7) restrict writeonly buffer Positions { vec4 positions[]; };      // [instances][N], w = 1

void main()
{
	uint i = gl_GlobalInvocationID.x;
	if (i >= vertex_count)
		return;
	uint instance = gl_WorkGroupID.y;
	uint matrices = instance * joint_count * 3u;
	vec4 m0 = vec4(0.0), m1 = vec4(0.0), m2 = vec4(0.0); // the blended matrix, row by row
	for (uint k = 0u; k < influence_count; ++k)
	{
		uint e = i * influence_count + k;
		float w = skin_weights[e];
		uint joint = matrices + 3u * skin_indices[e];
		m0 += w * skin_matrices[joint];
		m1 += w * skin_matrices[joint + 1u];
		m2 += w * skin_matrices[joint + 2u];
	}
	vec4 p = vec4(deformed[instance * vertex_count + i].xyz, 1.0);
	vec3 x = vec3(dot(m0, p), dot(m1, p), dot(m2, p));
	positions[instance * vertex_count + i] = vec4(x, 1.0);
}
