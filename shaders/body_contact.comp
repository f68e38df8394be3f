#version 430 core
// Body-contact job (pleat.h, BODY CONTACT): after skinning, a vertex closer than the clearance to the posed tangent
// plane of its anchor moves out along the anchor's normal to that distance. The anchor is made from the vertex's
// candidate body points nearest to it in this pose (asset 1.2; 1.1 has one point per vertex, the identity table). Three
// passes, as the three kernels of sdk/src/body_contact.c and pose_contact_points + body_contact of
// tools/pleat/reference/body_contact.py:
//   PLEAT_POSE_POINTS 1 (plPoseBodyPoints_Scalar), one invocation per body point p:
//     M_p = sum_k point_skin_weights[p][k] * M_{point_skin_indices[p][k]}
//     a = M_p * (r_p, 1) for every point (one that never anchors may still be in the ring of one that does),
//     n = normalize(M_p[:, :3] * point_normals[p])  -> posed[p]
//     anchorable iff the rest normal is non-zero; usable iff anchorable and |n| > 1e-12
//   PLEAT_POSE_POINTS 2 (plBodyPointNormals_Scalar; asset 1.2 with BARG only), one invocation per body point p:
//     with its ring r_0..r_{m-1} (counter-clockwise seen from outside) and d_i = a_{r_i} - a_p,
//     n = normalize(sum_i cross(d_i, d_{(i+1) mod m})), the posed body's own area-weighted normal (its closed fan);
//     usable iff |n| > 1e-12. A point without a ring, or not anchorable, keeps its rows of pass 1.
//   PLEAT_POSE_POINTS 0 (plBodyContact_Scalar, candidate_weights + body_contact), one invocation per vertex:
//     m = min over usable candidates |x - a_c|^2
//     w_c = max(0, (1 + PLEAT_CONTACT_BLEND_SHARE) m + PLEAT_CONTACT_BLEND_M^2 - |x - a_c|^2)
//     a = sum w_c a_c / sum w_c,  n = normalize(sum w_c n_c),  d = dot(x - a, n),  x += r max(0, offset - d) n
//     with the reach r = clamp((FAR^2 - m) / (FAR^2 - NEAR^2), 0, 1) (plContactReach: a plane centimetres away says
//     little about where the body is; r = 0 leaves the vertex as it is)
// A posed point is two rows, (a, anchorable), (n, usable), as the CPU's posed rows are too: pass 2 reads
// the first row of the points around it while it sets usable, so usable lives in the second row, the only one pass 2
// writes (of its own point only): no invocation writes what another one reads.
// Why a blend of the nearest few and not the nearest alone: the nearest jumps from one point to the next as the vertex
// moves, and the push would jump with it; the weights are continuous in x, so this fp32 path and the CPU's agree to
// rounding even where two candidates are almost equally near. The points are posed once per frame rather than once
// per vertex and candidate: a vertex has up to PLEAT_MAX_CONTACT_CANDIDATES and neighbouring vertices share most of
// them. They are skinned with the body's own weights (not the garment's diffused ones), so a is where the body surface
// is; the normal from the posed ring because the blended matrix turns the rest normal by the joints' rotations only,
// which tilts it off the stretched and folded skin at the shoulders, armpits and waist (docs/accuracy.md "Body
// contact"). PLEAT_MAX_CONTACT_CANDIDATES, PLEAT_CONTACT_BLEND_SHARE, PLEAT_CONTACT_BLEND_M and the two
// PLEAT_CONTACT_REACH_* come from
// sdk/src/kernels.h (gl_deformer.c injects them after the #version line, with the pass and batch defines).
// Batches (plStepInstances, sdk/src/gl/gl_deformer.c plGlDeformer_RunBatch): gl_WorkGroupID.y is the instance, and
// every per-instance buffer holds one block per instance at that index; a single instance is instance 0. The batch's
// programs are compiled with PLEAT_BATCH 1 (injected after the #version line): each instance's contact setting then
// comes from BatchContact instead of the params block.
#ifndef PLEAT_BATCH
#define PLEAT_BATCH 0
#endif
#ifndef PLEAT_POSE_POINTS
#define PLEAT_POSE_POINTS 0
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
	uint shaped_rows;            // rows of ShapedTemplate per instance: N + P
	uint point_count;            // P
	uint candidate_count;        // C
	uint point_ring_count;       // R entries of each body point's ring (0: no BARG, pass 2 is not run)
	uint contact_reach;          // 1: the push fades with the nearest candidate's distance (a candidate table); 0: not
};

#if PLEAT_BATCH
// Each instance of a batch has its own contact setting: (enabled 0 or 1, clearance in metres, 0, 0), C twin plGlVec4.
layout(std430, binding = 16) restrict readonly buffer BatchContact { vec4 batch_contact[]; }; // [instances]
#endif

#if PLEAT_POSE_POINTS == 1
// Per instance, rows 0..N-1: the shaped template (blend_shapes.comp); rows N..N+P-1: the body points of the same beta.
layout(std430, binding = 0) restrict readonly buffer ShapedTemplate { vec4 shaped[]; };
layout(std430, binding = 6) restrict readonly buffer SkinMatrices { vec4 skin_matrices[]; }; // [instances][J][3]
layout(std430, binding = 13) restrict readonly buffer PointNormals { vec4 point_normals[]; };           // [P]
layout(std430, binding = 14) restrict readonly buffer PointSkinIndices { uint point_skin_indices[]; };  // [P][Ka]
layout(std430, binding = 15) restrict readonly buffer PointSkinWeights { float point_skin_weights[]; }; // [P][Ka]
// Two rows per point: (a, anchorable 1 or 0), (n, usable 1 or 0); n is 0 when not usable.
layout(std430, binding = 17) restrict writeonly buffer PosedPoints { vec4 posed[]; }; // [instances][P][2]

void main()
{
	uint p = gl_GlobalInvocationID.x;
	if (p >= point_count)
		return;
	uint instance = gl_WorkGroupID.y;
#if PLEAT_BATCH
	if (batch_contact[instance].x == 0.0)
		return; // contact off for this instance: its push pass reads nothing
#endif
	uint matrices = instance * joint_count * 3u;
	vec4 m0 = vec4(0.0), m1 = vec4(0.0), m2 = vec4(0.0); // the point's blended matrix, row by row
	for (uint k = 0u; k < anchor_influence_count; ++k)
	{
		uint e = p * anchor_influence_count + k;
		float w = point_skin_weights[e];
		uint joint = matrices + 3u * point_skin_indices[e];
		m0 += w * skin_matrices[joint];
		m1 += w * skin_matrices[joint + 1u];
		m2 += w * skin_matrices[joint + 2u];
	}
	vec4 r = vec4(shaped[instance * shaped_rows + vertex_count + p].xyz, 1.0);
	vec3 rest_normal = point_normals[p].xyz;
	bool anchorable = rest_normal != vec3(0.0); // a zero rest normal: the asset left this point out of the anchors
	vec3 n = vec3(dot(m0.xyz, rest_normal), dot(m1.xyz, rest_normal), dot(m2.xyz, rest_normal));
	float len = length(n);
	bool usable = anchorable && len > 1e-12; // a degenerate blend: no plane to keep the vertex out of
	uint out_row = 2u * (instance * point_count + p);
	posed[out_row] = vec4(dot(m0, r), dot(m1, r), dot(m2, r), anchorable ? 1.0 : 0.0);
	posed[out_row + 1u] = usable ? vec4(n / len, 1.0) : vec4(0.0);
}

#elif PLEAT_POSE_POINTS == 2
// Each point's ring: the m >= 3 points around it, counter-clockwise seen from outside, then indices >= P (0xFFFF); a
// first entry >= P = no ring.
layout(std430, binding = 19) restrict readonly buffer PointRings { uint point_rings[]; }; // [P][R]
// Reads the first row of the points in the ring (pass 1 wrote them), writes the second row of its own point only.
layout(std430, binding = 17) restrict buffer PosedPoints { vec4 posed[]; }; // [instances][P][2]

void main()
{
	uint p = gl_GlobalInvocationID.x;
	if (p >= point_count)
		return;
	uint instance = gl_WorkGroupID.y;
#if PLEAT_BATCH
	if (batch_contact[instance].x == 0.0)
		return; // contact off for this instance: pass 1 posed nothing
#endif
	uint points = instance * point_count;
	uint row = 2u * (points + p);
	vec4 a = posed[row];
	uint ring = p * point_ring_count;
	if (a.w == 0.0 || point_rings[ring] >= point_count)
		return; // not an anchor, or no ring: the rows of pass 1 stand
	// n = sum d_i x d_{i+1} around the fan, the last one closing on d_0: summed as it goes, in the CPU's order.
	vec3 first = posed[2u * (points + point_rings[ring])].xyz - a.xyz;
	vec3 u = first, n = vec3(0.0);
	for (uint i = 1u; i < point_ring_count && point_rings[ring + i] < point_count; ++i)
	{
		vec3 v = posed[2u * (points + point_rings[ring + i])].xyz - a.xyz;
		n += vec3(u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x);
		u = v;
	}
	n += vec3(u.y * first.z - u.z * first.y, u.z * first.x - u.x * first.z, u.x * first.y - u.y * first.x);
	float len = length(n);
	posed[row + 1u] = len > 1e-12 ? vec4(n / len, 1.0) : vec4(0.0);
}

#else
layout(std430, binding = 7) restrict buffer Positions { vec4 positions[]; };                    // [instances][N]
layout(std430, binding = 17) restrict readonly buffer PosedPoints { vec4 posed[]; };            // [instances][P][2]
// Empty slots hold an index >= P (PLEAT_NO_CONTACT_CANDIDATE); a 1.1 asset gets the identity, C = 1.
layout(std430, binding = 18) restrict readonly buffer ContactCandidates { uint candidates[]; }; // [N][C]

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
	uint points = instance * point_count;
	vec3 x = positions[instance * vertex_count + i].xyz;
	// The usable candidates and their squared distances, then the nearest.
	uint rows[PLEAT_MAX_CONTACT_CANDIDATES];
	float d2[PLEAT_MAX_CONTACT_CANDIDATES];
	uint count = 0u;
	float nearest = 0.0;
	for (uint c = 0u; c < candidate_count; ++c)
	{
		uint p = candidates[i * candidate_count + c];
		if (p >= point_count)
			continue; // an empty slot (PLEAT_NO_CONTACT_CANDIDATE)
		uint row = 2u * (points + p);
		if (posed[row + 1u].w == 0.0)
			continue; // not usable in this pose
		vec3 delta = x - posed[row].xyz;
		rows[count] = row;
		d2[count] = delta.x * delta.x + delta.y * delta.y + delta.z * delta.z;
		nearest = count == 0u || d2[count] < nearest ? d2[count] : nearest;
		count++;
	}
	if (count == 0u)
		return; // no candidate: the vertex is far from the rest body
	float limit = (1.0 + PLEAT_CONTACT_BLEND_SHARE) * nearest + PLEAT_CONTACT_BLEND_M * PLEAT_CONTACT_BLEND_M;
	float total = 0.0;
	vec3 a = vec3(0.0), n = vec3(0.0);
	for (uint k = 0u; k < count; ++k)
	{
		float w = limit - d2[k];
		if (w > 0.0)
		{
			total += w;
			a += w * posed[rows[k]].xyz;
			n += w * posed[rows[k] + 1u].xyz;
		}
	}
	float len = length(n);
	float near2 = PLEAT_CONTACT_REACH_NEAR_M * PLEAT_CONTACT_REACH_NEAR_M;
	float far2 = PLEAT_CONTACT_REACH_FAR_M * PLEAT_CONTACT_REACH_FAR_M;
	float reach = contact_reach != 0u ? clamp((far2 - nearest) / (far2 - near2), 0.0, 1.0) : 1.0;
	if (!(total > 0.0) || !(len > 1e-12) || !(reach > 0.0))
		return; // normals that cancel (a thin body part seen from its edge), or a plane too far: no push
	a /= total;
	n /= len;
	float d = dot(x - a, n);
	if (d < offset_m)
		positions[instance * vertex_count + i] = vec4(x + ((offset_m - d) * reach) * n, 1.0);
}
#endif
