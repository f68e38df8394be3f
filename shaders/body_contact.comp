#version 430 core
// Body-contact job (pleat.h, BODY CONTACT): after skinning, a vertex closer than the clearance to its body anchor's
// posed tangent plane moves out along the anchor's normal to that distance:
//     M_a = sum_k anchor_skin_weights[i][k] * M_{anchor_skin_indices[i][k]}
//     a = M_a * (anchor, 1),  n = normalize(M_a[:, :3] * anchor_normal),  d = dot(x - a, n)
//     x += max(0, offset - d) * n
// Same loop as sdk/src/body_contact.c and tools/pleat/reference/body_contact.py. A zero rest normal means no anchor;
// so does a blended normal shorter than 1e-12. One invocation per vertex.
// Batches (plStepInstances, sdk/src/gl/gl_deformer.c plGlDeformer_RunBatch): gl_WorkGroupID.y is the instance, and
// every per-instance buffer holds one block per instance at that index; a single instance is instance 0. The batch's
// program is compiled with PLEAT_BATCH 1 (injected after the #version line): each instance's contact setting then
// comes from BatchContact instead of the params block.
#ifndef PLEAT_BATCH
#define PLEAT_BATCH 0
#endif

layout(local_size_x = 64) in;

// C twin: plGlDeformParams (sdk/src/gl/gl_types.h).
layout(std140, binding = 0) uniform plGlDeformParams
{
	uint vertex_count;           // N
	uint blend_count;            // D
	uint influence_count;        // K
	uint joint_count;            // J
	uint face_count;             // F
	uint anchor_influence_count; // Ka
	float body_contact_offset_m; // clearance (metres)
	uint shaped_rows;            // rows of ShapedTemplate per instance: 2N
};

// Per instance, rows 0..N-1: the shaped template (blend_shapes.comp); rows N..2N-1: the body anchors of the same beta.
layout(std430, binding = 0) restrict readonly buffer ShapedTemplate { vec4 shaped[]; };
#if PLEAT_BATCH
// Each instance of a batch has its own contact setting: (enabled 0 or 1, clearance in metres, 0, 0), C twin plGlVec4.
layout(std430, binding = 16) restrict readonly buffer BatchContact { vec4 batch_contact[]; }; // [instances]
#endif
layout(std430, binding = 6) restrict readonly buffer SkinMatrices { vec4 skin_matrices[]; }; // [instances][J][3]
layout(std430, binding = 7) restrict buffer Positions { vec4 positions[]; };                 // [instances][N]
layout(std430, binding = 13) restrict readonly buffer AnchorNormals { vec4 anchor_normals[]; };           // [N]
layout(std430, binding = 14) restrict readonly buffer AnchorSkinIndices { uint anchor_skin_indices[]; };  // [N][Ka]
layout(std430, binding = 15) restrict readonly buffer AnchorSkinWeights { float anchor_skin_weights[]; }; // [N][Ka]

void main()
{
	uint i = gl_GlobalInvocationID.x;
	if (i >= vertex_count)
		return;
	uint instance = gl_WorkGroupID.y;
#if PLEAT_BATCH
	if (batch_contact[instance].x == 0.0)
		return;
	float offset_m = batch_contact[instance].y;
#else
	float offset_m = body_contact_offset_m;
#endif
	uint matrices = instance * joint_count * 3u;
	vec3 rest_normal = anchor_normals[i].xyz;
	if (rest_normal == vec3(0.0))
		return; // no anchor: the vertex is far from the rest body
	vec4 m0 = vec4(0.0), m1 = vec4(0.0), m2 = vec4(0.0); // the anchor's blended matrix, row by row
	for (uint k = 0u; k < anchor_influence_count; ++k)
	{
		uint e = i * anchor_influence_count + k;
		float w = anchor_skin_weights[e];
		uint joint = matrices + 3u * anchor_skin_indices[e];
		m0 += w * skin_matrices[joint];
		m1 += w * skin_matrices[joint + 1u];
		m2 += w * skin_matrices[joint + 2u];
	}
	vec4 r = vec4(shaped[instance * shaped_rows + vertex_count + i].xyz, 1.0);
	vec3 a = vec3(dot(m0, r), dot(m1, r), dot(m2, r));
	vec3 n = vec3(dot(m0.xyz, rest_normal), dot(m1.xyz, rest_normal), dot(m2.xyz, rest_normal));
	float len = length(n);
	if (!(len > 1e-12))
		return; // a degenerate blend has no direction to push along
	n /= len;
	vec3 x = positions[instance * vertex_count + i].xyz;
	float d = dot(x - a, n);
	if (d < offset_m)
		positions[instance * vertex_count + i] = vec4(x + (offset_m - d) * n, 1.0);
}
