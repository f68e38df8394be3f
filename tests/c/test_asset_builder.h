// Test helper: builds small Pleat assets (format v1.0) in C, so the loader, guard and bad-input tests need no Python.
// The model is plain arrays a test may edit before plTestAsset_Write serialises it (64-byte aligned sections,
// NADO/NADF computed, CRC-32 stamped).
#ifndef PLEAT_TEST_ASSET_BUILDER_H
#define PLEAT_TEST_ASSET_BUILDER_H
#include <stddef.h>
#include <stdint.h>

typedef struct plTestLayer
{
	uint32_t in_count, out_count;
	float* weight; // [out][in]
	float* bias;   // [out]
} plTestLayer;

typedef struct plTestAssetParams
{
	uint32_t grid_x, grid_y;     // vertex grid (a sheet in the XY plane at z = 0.1), N = grid_x · grid_y
	uint32_t joint_count;        // a chain along +Y
	uint32_t input_joint_count;  // input joints 1..Jin
	uint32_t influence_count;
	uint32_t beta_count;
	uint32_t latent_count;
	uint32_t blend_count;
	uint32_t lp_hidden[4];       // hidden widths of f_LP (0-terminated)
	uint32_t dec_hidden[4];      // hidden widths of f_dec (0-terminated)
	uint32_t activation;         // 1 ReLU, 2 SiLU
	float weight_scale;          // random weights uniform in ±weight_scale / sqrt(in); 0 = all network weights zero
	float blend_scale;           // blend shapes uniform in ±blend_scale metres
	uint32_t seed;
	int fp16;                    // store LPW/DCW/BLND as fp16
	int int8_blend_shapes;       // store BLND as int8 with a scale per shape (asset 1.4; BLSC), whatever fp16 says
} plTestAssetParams;

typedef struct plTestAsset
{
	uint32_t N, F, J, Jin, K, B, L, D, I;
	uint32_t lp_count, dec_count, lp_activation, dec_activation;
	plTestLayer lp[10], dec[10];
	float dt_min_s, dt_max_s, beta_min, beta_max, material_min[4], material_max[4], material_default[4], train_fps;
	char name[65];
	char joint_names[64][32];
	int32_t parents[64];
	float joint_template[64 * 3];
	float* joint_shapedirs; // [B][J][3]
	uint32_t input_joints[64];
	float* template_positions; // [N][3]
	float* shape_blend;        // [B][N][3]
	uint32_t* faces;           // [F][3]
	uint16_t* skin_indices;    // [N][K]
	float* skin_weights;       // [N][K]
	float *x_mean, *x_std;     // [I]
	float *z_mean, *z_std, *z_min, *z_max; // [L]
	float* blend_shapes;       // [D][N][3] (with int8 shapes, their values q · scale)
	int8_t* blend_shapes_int8; // [D][N][3] or NULL: BLND as int8, with blend_scales [D] (BLSC)
	float* blend_scales;
	int fp16;
	const char* meta;
	uint16_t version_major, version_minor;
	const void* onnx_lp; size_t onnx_lp_size; // optional OXLP payload
	const void* onnx_dec; size_t onnx_dec_size;
	// Optional body contact (BANC/BASH/BANN/BASI/BASW for P points, and BACA, each vertex's candidates, unless
	// body_candidates is NULL: then P = N, asset 1.1), NULL = none: see plTestAsset_AddBodyAnchors.
	uint32_t P;                      // body points
	uint32_t C;                      // candidates per vertex
	float* body_anchors;             // [P][3]
	float* body_anchor_shape;        // [B][P][3]
	float* body_anchor_normals;      // [P][3]
	uint16_t* body_anchor_skin_indices; // [P][K]
	float* body_anchor_skin_weights;    // [P][K]
	uint16_t* body_candidates;          // [N][C] or NULL
	uint16_t* body_ring;                // [P][PLEAT_TEST_POINT_RING] (BARG) or NULL
} plTestAsset;

#define PLEAT_TEST_POINT_RING 8

plTestAssetParams plTestAsset_DefaultParams( void );
// Returns NULL on allocation failure.
plTestAsset* plTestAsset_Create( const plTestAssetParams* params );
void plTestAsset_Destroy( plTestAsset* asset );
// Gives the sheet a stand-in body (asset 1.2): P = N + ⌈N/4⌉ points shaped and skinned like the sheet. Point v < N
// lies depth_m behind vertex v (normal +Z; every fifth has a zero normal and never anchors); point N + j lies 1 mm
// beside vertex 4j and half as deep, its normal tilted towards +X. Candidates (C = 3): vertex v has point v, then
// point N + v/4 for v % 4 == 0, then an empty slot; every seventh vertex (v % 7 == 3) has none at all. So vertices
// 4j mostly take the tilted point, and blend shapes larger than depth_m push vertices through both. Rings (BARG): point
// v < N at an interior grid vertex has the grid vertices around v, counter-clockwise seen from +Z (so its posed normal
// is the stand-in's, +Z at rest); edge vertices and the extra points have none (the blended rest normal). 0 on failure.
int plTestAsset_AddBodyAnchors( plTestAsset* asset, float depth_m );
// Makes f_LP overflow whenever the root moves along x (a numeric reset), as test_guards does: X_c's root velocity x gets
// x_std 1e-38 and f_LP's first layer weighs it with ±6e4 (within fp16's range); standing still stays finite. Use with
// SiLU networks, which pass ±inf and NaN on (a ReLU would turn an overflow's NaN into 0).
void plTestAsset_OverflowOnRootMotion( plTestAsset* asset );
// int8 blend shapes (asset 1.4): per shape the scale max |D_j| / 127 and q = round(D_j / scale), and blend_shapes
// replaced by what the file then holds, q · scale (so references computed from them match). Done by plTestAsset_Create
// when params.int8_blend_shapes is set.
void plTestAsset_QuantiseBlendShapes( plTestAsset* asset );
// Back to one point per vertex (asset 1.1, no candidate or face table): point v for vertex v, the extra points dropped.
void plTestAsset_DropBodyCandidates( plTestAsset* asset );
// Serialises into a 64-byte aligned block (free with plTestAsset_FreeBytes). Returns NULL on failure.
uint8_t* plTestAsset_Write( const plTestAsset* asset, size_t* out_size );
void plTestAsset_FreeBytes( uint8_t* bytes );
// Recomputes the header CRC-32 after a test edited the bytes.
void plTestAsset_FixChecksum( uint8_t* bytes, size_t size );
// Byte offset of a section's data (fourcc) in a written asset, or 0 if absent.
size_t plTestAsset_SectionOffset( const uint8_t* bytes, const char* fourcc );
// Byte offset of a section's table entry, or 0 if absent.
size_t plTestAsset_SectionEntryOffset( const uint8_t* bytes, const char* fourcc );

// FNV-1a over bytes (output hashes for the determinism and twin tests).
uint64_t plTestHash( const void* data, size_t size, uint64_t seed );

#endif
