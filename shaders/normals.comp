#version 430 core
// Normals job, area weighted, gathered per vertex over the CSR adjacency (asset sections NADO/NADF), so the sum has a
// fixed order and needs no atomics (docs/inputs.md "Network evaluation"):
//     normals[i] = normalize(sum over faces f = (a, b, c) of vertex i of cross(x_b - x_a, x_c - x_a))
// Same loop as sdk/src/normals.c and tools/pleat/reference/normals.py; a zero sum gives a zero normal.

layout(local_size_x = 64) in;

// C twin: plGlDeformParams (sdk/src/gl/gl_types.h).
layout(std140, binding = 0) uniform plGlDeformParams
{
	uint vertex_count;    // N
	uint blend_count;     // D
	uint influence_count; // K
	uint joint_count;     // J
};

layout(std430, binding = 7) restrict readonly buffer Positions { vec4 positions[]; };               // [N]
layout(std430, binding = 8) restrict readonly buffer Faces { uint faces[]; };                       // [F][3]
layout(std430, binding = 9) restrict readonly buffer AdjacencyOffsets { uint adjacency_offsets[]; }; // [N + 1]
layout(std430, binding = 10) restrict readonly buffer AdjacencyFaces { uint adjacency_faces[]; };    // [3F]
layout(std430, binding = 11) restrict writeonly buffer Normals { vec4 normals[]; };                  // [N] xyz, w = 0

void main()
{
	uint i = gl_GlobalInvocationID.x;
	if (i >= vertex_count)
		return;
	vec3 n = vec3(0.0);
	uint end = adjacency_offsets[i + 1u];
	for (uint e = adjacency_offsets[i]; e < end; ++e)
	{
		uint f = 3u * adjacency_faces[e];
		vec3 a = positions[faces[f]].xyz;
		vec3 b = positions[faces[f + 1u]].xyz;
		vec3 c = positions[faces[f + 2u]].xyz;
		n += cross(b - a, c - a);
	}
	float length_sq = dot(n, n);
	normals[i] = vec4(length_sq > 0.0 ? n * inversesqrt(length_sq) : vec3(0.0), 0.0);
}
