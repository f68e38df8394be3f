// Internal: a loaded, validated asset (docs/asset-format.md). Every pointer points into the one 64-byte aligned block
// (or, for what the load derives for the kernels, into derived_block). The loader's files fill it: asset_format.c
// reads the container, asset_validate.c the sections and what they mean, asset_derive.c the kernels' tables.
#ifndef PLEAT_ASSET_DATA_H
#define PLEAT_ASSET_DATA_H
#include "kernels/kernels.h"
#include "pleat/pleat.h"

#include <stddef.h>
#include <stdint.h>

typedef struct plAssetData
{
	const uint8_t* block; // the whole file, 64-byte aligned
	size_t size;
	void* owned_block;    // non-NULL if the SDK allocated (and must free) the block
	size_t owned_size;
	void* derived_block;  // what the load derives for the kernels (plDeriveKernelData), or NULL
	size_t derived_size;
	size_t batch_scratch_floats; // what plStepInstances's lanes forms need of a context scratch block for this asset
	                             // with the context's kernels (0: none; instance creation reserves it)
	uint32_t instance_count; // live instances using this asset

	// CONF
	uint32_t vertex_count, face_count, joint_count, input_joint_count, influence_count, beta_count, latent_count,
		blend_count, lp_layer_count, dec_layer_count, lp_activation, dec_activation, input_count;
	float dt_min_s, dt_max_s, beta_min, beta_max, train_fps;
	float material_min[4], material_max[4], material_default[4];
	int weights_fp16;
	int weights_int8; // the header's int8 flag: every LP and decoder layer is int8 (plLayer.weight_int8)

	char name[65];
	const char* meta;          // [meta_size] utf-8 JSON, or NULL
	size_t meta_size;
	const char* joint_names;   // [J][32] NUL-padded, each has a NUL
	const int32_t* parents;    // [J]
	const float* joint_template;  // [J][3] metres
	const float* joint_shapedirs; // [B][J][3] metres per unit β
	const uint32_t* input_joints; // [Jin]
	const float* template_positions; // [N][3] metres, rest space
	const float* shape_blend;        // [B][N][3]
	const uint32_t* faces;           // [F][3]
	const uint32_t* adjacency_offsets; // [N + 1]
	const uint32_t* adjacency_faces;   // [3F]
	const uint16_t* skin_indices;      // [N][K]
	const float* skin_weights;         // [N][K]
	const float* x_mean;  // [I]
	const float* x_std;   // [I]
	const float* z_mean;  // [L]
	const float* z_std;   // [L]
	const float* z_min;   // [L]
	const float* z_max;   // [L]
	plLayer lp[PLEAT_MAX_LAYERS];
	plLayer dec[PLEAT_MAX_LAYERS];
	plBlendShapes blend_shapes; // [D][N][3] fp32, fp16 or (asset 1.4) int8 with a scale per shape
	const uint32_t* pinned; // [P] or NULL
	// Body contact (asset 1.1, optional, all or none): P body points, each a rest position, its shape directions, its
	// unit normal (zero = never an anchor) and the body's skinning there; asset 1.2 adds each vertex's candidate points
	// (BACA), 1.1 has one point per vertex (P = N, vertex v's is point v). docs/asset-format.md "Body contact".
	const float* body_anchors;          // [P][3] or NULL
	const float* body_anchor_shape;     // [B][P][3]
	const float* body_anchor_normals;   // [P][3]
	const uint16_t* body_anchor_skin_indices; // [P][Ka]
	const float* body_anchor_skin_weights;    // [P][Ka]
	uint32_t body_anchor_influence_count;     // Ka (1..8), 0 without anchors
	uint32_t body_point_count;                // P (0 without anchors)
	const uint16_t* body_anchor_candidates;   // [N][C] point indices, PLEAT_NO_CONTACT_CANDIDATE = empty; NULL: 1.1
	uint32_t body_anchor_candidate_count;     // C (1..PLEAT_MAX_CONTACT_CANDIDATES; 1 for 1.1)
	const uint16_t* body_anchor_ring;         // [P][R] each point's ring of points (BARG, asset 1.2) or NULL
	uint32_t body_anchor_ring_count;          // R (3..PLEAT_MAX_POINT_RING), 0 without BARG
	const int32_t* body_anchor_ring_lanes;    // the rings in lanes (plRingLanes; in derived_block), with the rings
	const uint32_t* body_contact_row_offsets; // the candidates as posed rows' offsets (plContactRowOffsets; in
											  // derived_block), with body points
	const uint32_t* skin_column_offsets;      // skin_indices as column-block offsets (plSkinColumnOffsets; in
											  // derived_block)
	const uint32_t* body_anchor_column_offsets; // body_anchor_skin_indices the same way, with body points
	int body_contact_fast_ready;              // the fast contact can run: P >= N and every vertex's first candidate
	                                          // is its own point v (or none), so rows 0..N-1 are the 1.1 layout
	uint32_t pinned_count;
	const void* onnx_lp;    // OXLP or NULL
	size_t onnx_lp_size;
	const void* onnx_dec;   // OXDC or NULL
	size_t onnx_dec_size;

	// Set by a failed parse whose check has more to say than its result code (else PLEAT_LOG_NONE): plLoadAsset logs
	// this item and detail instead of the item the result maps to.
	plLogItem rejected_item;
	char rejected_detail[128];
} plAssetData;

#endif
