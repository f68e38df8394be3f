// Internal: the CPU kernels and their dispatch table. The scalar kernels (mlp.c, blend_shapes.c, skinning.c, normals.c)
// are the specification; the AVX2 + FMA + F16C variants (*_avx2.c, compiled with per-file flags) have the same names
// with an _Avx2 suffix. One table (plKernels) holds a context's single-instance kernels and their batched twins; it is
// chosen once at context creation (plChooseKernels) and every step, crowd and scene reads it as it is.
#ifndef PLEAT_KERNELS_H
#define PLEAT_KERNELS_H
#include "pleat/pleat.h"

#include <math.h>
#include <stddef.h>
#include <stdint.h>

// Rows [row_begin, row_end) of a layer whose weights are zero outside columns [col_begin, col_end); col_begin is a
// multiple of 16 and col_end a multiple of 16 or in_count, so the SIMD kernels' FMA chains over the window are
// those of the whole row, and a window gives the whole row's bits (the skipped products are all 0 · x).
typedef struct plLayerBlock
{
	uint32_t row_begin, row_end;
	uint32_t col_begin, col_end;
} plLayerBlock;
#define PLEAT_MAX_LAYER_BLOCKS 8

// One Linear layer of an MLP as the asset stores it (read in place); the MLP job runs a chain of them.
typedef struct plLayer
{
	const void* weight; // [out][in] row-major (torch Linear.weight), fp32, fp16 or int8
	int weight_fp16;
	const float* bias;  // [out]
	// int8 layers (asset flag PLEAT_FLAG_INT8, docs/asset-format.md "int8 networks"): weight is int8 in [−127, 127],
	// weight_scale [out] each output channel's scale, input_scale [1] the scale the layer's input is quantised with
	// (calibrated offline) and input_inv_scale = 1 / input_scale, worked out once at load (plMatVecInt8Fn);
	// int8_input where that input is quantised to (plInt8Input) and weight_sums [out] each row's Σ w over its window
	// (asset_derive.c), which a HIDDEN input's held q − 128 and the crowd's biased inputs leave out of the sum.
	int weight_int8;
	const float* weight_scale;
	const float* input_scale;
	float input_inv_scale;
	uint32_t int8_input;
	const int32_t* weight_sums;
	uint32_t in_count;
	uint32_t out_count;
	// 0: dense. Else the rows cut into blocks, each multiplied over its own column window only (layer_blocks.c finds
	// them at load: a packed ensemble's block-diagonal layers, pleat.train.ensemble, cost what its members cost).
	uint32_t block_count;
	plLayerBlock blocks[PLEAT_MAX_LAYER_BLOCKS];
	// The single step's copy of a block layer whose windows all have one width: row r's weights over its block's
	// window only, [out][packed_width] (plPackLayer; the asset packs at load, NULL: none). Read in place, such a layer
	// streams its zero blocks too, as the hardware prefetchers follow each row past its window; the copy gives each
	// window's products in the same order, so the same bits.
	const void* packed;
	uint32_t packed_width;
} plLayer;

// Bytes of one of the layer's weights: 1 (int8), 2 (fp16) or 4 (fp32).
static inline uint32_t plWeightBytes( const plLayer* layer )
{
	return layer->weight_int8 ? 1u : ( layer->weight_fp16 ? 2u : 4u );
}

// The layer's blocks as the MLP jobs run them: block_count blocks, or one dense block covering the layer.
uint32_t plLayerBlocks( const plLayer* layer, plLayerBlock* blocks );
// The rows of `block` within a task's rows [begin, end) as [*row_begin, *row_end); 0 when they do not meet.
static inline int plBlockRowsWithin( const plLayerBlock* block, uint32_t begin, uint32_t end, uint32_t* row_begin,
									 uint32_t* row_end )
{
	*row_begin = block->row_begin > begin ? block->row_begin : begin;
	*row_end = block->row_end < end ? block->row_end : end;
	return *row_begin < *row_end;
}
// Multiply-adds of one evaluation of the layer as its blocks run (in_count · out_count when dense).
uint64_t plLayerMacs( const plLayer* layer );
// Finds the blocks of a layer whose weights are block-structured (rows in 2, 3, 4, 6 or 8 equal parts, each with zeros
// outside one column window) when that saves at least a quarter of the multiply-adds; leaves block_count 0 otherwise.
void plFindLayerBlocks( plLayer* layer );
// Bytes of the layer's packed copy (plLayer.packed): 0 unless it has blocks whose windows all have one width > 0.
size_t plPackedLayerBytes( const plLayer* layer );
// Copies each row's window into dst (plPackedLayerBytes of them) and points layer->packed at it.
void plPackLayer( plLayer* layer, void* dst );

// Activation on the hidden layers (asset CONF lp_activation / dec_activation).
#define PLEAT_ACTIVATION_RELU 1
#define PLEAT_ACTIVATION_SILU 2
// y[r] = activation(y[r]) for r < count (mlp.c; the MLP job and its batched twin share it).
void plApplyActivation( float* y, uint32_t count, uint32_t activation );

// out[r] = bias[r] + Σ_c W[r][c] · x[c] over columns c in [col_begin, col_end) (a plLayerBlock's window; 0, in_count
// for a dense layer) for rows [row_begin, row_end); W is [rows][in_count] row-major, fp32 or fp16.
typedef void plMatVecFn( float* out, const float* x, const void* weight, int weight_fp16, const float* bias,
						 uint32_t in_count, uint32_t col_begin, uint32_t col_end, uint32_t row_begin,
						 uint32_t row_end );
// Where an int8 layer's input is quantised to (docs/asset-format.md "int8 networks"; pleat.reference.mlp
// int8_input_bounds). Without the asset's ranged-inputs flag every layer is SYMMETRIC. With it a network's first layer
// (the normalised inputs, the latent: either sign) takes 12 bits, FIRST, held as int16; and each hidden layer (a ReLU
// output, never negative) takes 0..255, HIDDEN, held as q − 128 so that the SIMD kernels' sign trick keeps working
// (|q − 128| ≤ 128, two products ≤ 2 · 128 · 127 < 2¹⁵), the row's 128 · Σ w (weight_sums) added to the sum.
typedef enum plInt8Input
{
	PLEAT_INT8_INPUT_SYMMETRIC = 0, // −127..127
	PLEAT_INT8_INPUT_FIRST = 1,     // −2047..2047
	PLEAT_INT8_INPUT_HIDDEN = 2,    // 0..255
} plInt8Input;

// The int8 layer (asset flag PLEAT_FLAG_INT8): x quantised as q[c] = clamp(round_even(x[c] · input_inv_scale), lo,
// hi) with the layer's bounds (plQuantiseInput), acc[r] = Σ_c W[r][c] · q[c] over the window in int32,
// out[r] = (float)acc[r] · (weight_scale[r] · input_scale) + bias[r] (plDequantise). The sum is integer arithmetic,
// so every variant gives the scalar kernel's bits whatever its order; the float steps are one shared code. The scales,
// bias, bounds and offsets come from `layer`; the weights from `weight` [rows][stride] (the layer's own, or its packed
// copy), int8 in [−127, 127] (the loader checks: −128 would break the sign trick the SIMD kernels use);
// col_end − col_begin ≤ PLEAT_MAX_INT8_COLUMNS. No sum comes near 2³¹: 4096 · 127 · 2047 < 2³⁰.
typedef void plMatVecInt8Fn( float* out, const float* x, const plLayer* layer, const int8_t* weight, uint32_t stride,
							 uint32_t col_begin, uint32_t col_end, uint32_t row_begin, uint32_t row_end );
// The int8 layer for many instances of one asset (the crowd's MLP job, mlp_batch.c): the batch's inputs quantised
// once per layer into a block in the kernel set's own layout (plQuantiseInt8Fn; at most plInt8HeldBlockBytes), then
// rows [row_begin, row_end) over the window [col_begin, col_begin + columns) (col_begin a multiple of 4, as every
// block window's is) with each weight row read once for many instances; weight points at the window's first column
// of row 0, rows `stride` apart. Per instance exactly plMatVecInt8Fn's bits (integer sums; the same float ends).
typedef void plMatMatInt8Fn( float* const* out, const void* held, uint32_t batch_count, const plLayer* layer,
							 const int8_t* weight, uint32_t stride, uint32_t col_begin, uint32_t columns,
							 uint32_t row_begin, uint32_t row_end );
typedef void plQuantiseInt8Fn( void* held, const float* const* x, uint32_t batch_count, const plLayer* layer );
// Bytes of one held input value of an int8 layer in the single kernels (int16 for a FIRST input, else int8).
static inline uint32_t plInt8HeldBytes( const plLayer* layer )
{
	return layer->int8_input == PLEAT_INT8_INPUT_FIRST ? 2u : 1u;
}
// Bytes a batch's held inputs of an int8 layer take in any set's layout: sixteen-instance groups of 64-byte lines,
// two bytes a value.
static inline size_t plInt8HeldBlockBytes( const plLayer* layer, uint32_t batch_count )
{
	size_t groups = ( batch_count + 15u ) / 16u;
	return groups * 16u * ( ( (size_t)layer->in_count * 2u + 63u ) & ~(size_t)63u );
}
// An int8 layer's input is quantised into a buffer on the kernel's stack, so that the kernel needs no scratch and any
// split of the rows over workers quantises alike; the loader refuses wider int8 layers.
#define PLEAT_MAX_INT8_COLUMNS 4096
// x · inv_scale clamped to [lo, hi] (a NaN gives lo: fmaxf, as _mm256_max_ps with the bound second, returns the
// bound), rounded to nearest even by adding and subtracting 1.5 · 2²³ (exact for |v| < 2²²; the SIMD kernels' cvtps
// rounds the same way, and numpy's np.rint too).
static inline int32_t plQuantiseWithin( float x, float inv_scale, float lo, float hi )
{
	float v = fminf( fmaxf( x * inv_scale, lo ), hi );
	return (int32_t)( ( v + 12582912.0f ) - 12582912.0f ); // ISO C: each operation rounded to float
}
// The quantised value of a SYMMETRIC input, in [−127, 127].
static inline int8_t plQuantise( float x, float inv_scale )
{
	return (int8_t)plQuantiseWithin( x, inv_scale, -127.0f, 127.0f );
}
// The bounds of a plInt8Input, and what the kernels hold of q: q − held_offset.
static inline float plInt8InputLow( uint32_t input )
{
	return input == PLEAT_INT8_INPUT_FIRST ? -2047.0f : input == PLEAT_INT8_INPUT_HIDDEN ? 0.0f : -127.0f;
}
static inline float plInt8InputHigh( uint32_t input )
{
	return input == PLEAT_INT8_INPUT_FIRST ? 2047.0f : input == PLEAT_INT8_INPUT_HIDDEN ? 255.0f : 127.0f;
}
static inline int32_t plInt8InputHeldOffset( uint32_t input )
{
	return input == PLEAT_INT8_INPUT_HIDDEN ? 128 : 0;
}
// What the held values leave out of row r's sum: held offset · Σ w (0 unless the input is HIDDEN).
static inline int32_t plInt8RowOffset( const plLayer* layer, uint32_t r )
{
	return layer->int8_input == PLEAT_INT8_INPUT_HIDDEN ? 128 * layer->weight_sums[r] : 0;
}
// The value the kernels hold for x in a layer with input kind `input`: q − held offset (−2047..2047 or −128..127).
static inline int32_t plQuantiseInput( float x, float inv_scale, uint32_t input )
{
	return plQuantiseWithin( x, inv_scale, plInt8InputLow( input ), plInt8InputHigh( input ) ) -
		   plInt8InputHeldOffset( input );
}
// Non-zero unless an int8 layer lacks its scales or is wider than PLEAT_MAX_INT8_COLUMNS (the jobs' validation).
static inline int plInt8LayerIsValid( const plLayer* l )
{
	return !l->weight_int8 ||
		   ( !l->weight_fp16 && l->weight_scale != NULL && l->input_scale != NULL &&
			 l->in_count <= PLEAT_MAX_INT8_COLUMNS && l->int8_input <= PLEAT_INT8_INPUT_HIDDEN &&
			 ( l->int8_input != PLEAT_INT8_INPUT_HIDDEN || l->weight_sums != NULL ) );
}
// The float end of an int8 row: two roundings (a product, then a sum), never fused, as numpy computes it.
static inline float plDequantise( int32_t acc, float weight_scale, float input_scale, float bias )
{
	float scale = weight_scale * input_scale;
	float product = (float)acc * scale;
	return product + bias;
}

// IEEE half → float (exact, handles subnormals, inf, NaN).
float plHalfToFloat( uint16_t h );

// How an asset stores its blend shapes: fp32, fp16, or (asset 1.4, docs/asset-format.md "int8 blend shapes") int8 in
// [−127, 127] with one scale per shape.
enum
{
	PLEAT_SHAPES_F32 = 0,
	PLEAT_SHAPES_F16 = 1, // the value the asset reader's fp16 field sets
	PLEAT_SHAPES_I8 = 2
};

// A garment's blend shapes: [D][N][3] elements of `type`, and for int8 each shape's scale. The blend kernels read
// `data` and `type` only: an int8 element enters as (float)q, and its shape's scale enters through the weight the
// kernel is given (plFoldShapeScales), so an int8 shape costs the kernels no more arithmetic than an fp16 one.
typedef struct plBlendShapes
{
	const void* data;
	int type;            // PLEAT_SHAPES_*
	const float* scales; // [D] for PLEAT_SHAPES_I8, else NULL
} plBlendShapes;

// Element `index` of the shapes as every blend kernel reads it: fp32 as it is, fp16 widened (exact), int8 (float)q.
static inline float plShapeElement( const plBlendShapes* shapes, size_t index )
{
	if ( shapes->type == PLEAT_SHAPES_I8 )
	{
		return (float)( (const int8_t*)shapes->data )[index];
	}
	return shapes->type == PLEAT_SHAPES_F16 ? plHalfToFloat( ( (const uint16_t*)shapes->data )[index] )
											: ( (const float*)shapes->data )[index];
}

// Element `index` of shape j in metres: plShapeElement times the shape's scale for int8 (what the GL path uploads).
static inline float plShapeValue( const plBlendShapes* shapes, uint32_t j, size_t index )
{
	float e = plShapeElement( shapes, index );
	return shapes->type == PLEAT_SHAPES_I8 ? e * shapes->scales[j] : e;
}

// The weights the blend kernels take for these shapes: out[j] = weights[j] · scale_j for int8 shapes (one rounding,
// the same for a single step, a crowd and the tests), a copy otherwise. out may be weights.
static inline void plFoldShapeScales( float* out, const float* weights, const plBlendShapes* shapes,
									  uint32_t blend_count )
{
	for ( uint32_t j = 0; j < blend_count; ++j )
	{
		out[j] = shapes->type == PLEAT_SHAPES_I8 ? weights[j] * shapes->scales[j] : weights[j];
	}
}

// Bytes of one blend shape element.
static inline uint32_t plShapeBytes( int type )
{
	return type == PLEAT_SHAPES_I8 ? 1u : ( type == PLEAT_SHAPES_F16 ? 2u : 4u );
}

// out[v] = base[v] + Σ_j w[j] · shapes[j][v] for vertices [v_begin, v_end) (plShapeElement's values; for int8 shapes
// w carries the scales, plFoldShapeScales); out may be base.
typedef void plBlendShapesFn( float* out, const float* base, const plBlendShapes* shapes, const float* weights,
							  uint32_t blend_count, uint32_t vertex_count, uint32_t v_begin, uint32_t v_end );

// Linear blend skinning for vertices [v_begin, v_end): out[v] = (Σ_k w_vk M_{j_vk}) · (in[v], 1), M = [J][3][4]
// row-major; in/out are strided (bytes), 3 floats per vertex; joint indices >= joint_count count as weight 0.
// column_offsets (optional, here and in the posing and fast contact below): the same skin indices as column-block
// offsets (plSkinColumnOffsets), which the AVX2 kernels read instead of clamping and addressing each influence (the
// same bits either way).
typedef void plSkinningFn( float* out, uint32_t out_stride_bytes, const float* in, uint32_t in_stride_bytes,
						   const uint16_t* skin_indices, const float* skin_weights, uint32_t influence_count,
						   const uint32_t* column_offsets, const float* skin_matrices, uint32_t joint_count,
						   uint32_t v_begin, uint32_t v_end );
// The AVX2 kernels take the skinning matrices in column form (simd_avx2.h plSkinColumns): J' = min(J,
// PLEAT_SKIN_COLUMN_JOINTS) blocks of 16 floats, then a zero block, which an index >= J' reads.
#define PLEAT_SKIN_COLUMN_JOINTS 64 // PLEAT_MAX_JOINTS (pleat.h); the asset loader enforces it
// A skin table's indices [count] as those blocks' byte offsets, min(index, J') · 64 (asset.c builds them at load for
// the garment's and the body points' skins). Read per influence, they save the clamp and the address arithmetic: a
// quarter of the body posing's instructions (the t-shirt's step 89.9 -> 87.1 µs with the posing's alone).
void plSkinColumnOffsets( uint32_t* dst, const uint16_t* indices, size_t count, uint32_t joint_count );

// Unnormalised face normals cross(x_b − x_a, x_c − x_a) for faces [f_begin, f_end) into face_normals [F][4]
// (x, y, z, 0); positions [vertex_count] xyz with a byte stride; a face with an index >= vertex_count gets zero.
typedef void plFaceNormalsFn( float* face_normals, const float* positions, uint32_t position_stride_bytes,
							  uint32_t vertex_count, const uint32_t* faces, uint32_t f_begin, uint32_t f_end );
// Vertex normals for [v_begin, v_end): Σ of face_normals over the CSR adjacency in ascending order (entries past
// 3·face_count or naming a face >= face_count are skipped), normalised (zero if the sum is zero), written with a byte
// stride. Bit-identical across variants: per component the same additions in the same order, the same normalisation.
typedef void plNormalsGatherFn( float* normals, uint32_t normals_stride_bytes, const float* face_normals,
								uint32_t face_count, const uint32_t* adjacency_offsets, const uint32_t* adjacency_faces,
								uint32_t v_begin, uint32_t v_end );

// All vertex normals in one serial pass over the faces (no adjacency): each face's cross(x_b − x_a, x_c − x_a) (zero
// if an index is >= vertex_count) is added to the (x, y, z, 0) sums4 row of each of its in-range vertices in ascending
// face order, then every vertex is normalised as in the gather. For a valid asset (each vertex's adjacency = its faces
// in ascending order, which the loader checks) this is bit-identical to face normals + gather; one thread only.
// sums4: [vertex_count][4] scratch, 16-byte aligned.
typedef void plNormalsScatterFn( float* normals, uint32_t normals_stride_bytes, const float* positions,
								 uint32_t position_stride_bytes, uint32_t vertex_count, const uint32_t* faces,
								 uint32_t face_count, float* sums4 );

// Body contact (pleat.h BODY CONTACT, body_contact.c), in three kernels:
// Posing the body points [p_begin, p_end): M_p = Σ_k w_pk M_{j_pk}, a = M_p · (r_p, 1), n = normalize(M_p[:, :3] · n_p)
// into posed[p] = (a_x, a_y, a_z, anchorable, n_x, n_y, n_z, usable) (PLEAT_POSED_POINT_FLOATS floats, 32-byte rows):
// every point's position; anchorable is 1 where the rest normal is non-zero, usable where also the blended normal is
// longer than 1e-12 (else 0, and the normal 0). Rest points and normals [P][3], point skin [P][K]; joint indices
// >= joint_count count as weight 0. With rings (NULL: none), an anchorable point with a ring (rings[p][0] < P) gets
// its normal and usable as 0: the ring normals below overwrite them, so its blended normal (a square root, three
// divisions) is not worked out. The halves are the GL path's (shaders/body_contact.comp): the ring normals read the
// first half of other points' rows and write the second half of their own, so workers that split the points never
// write what another one reads (usable used to sit in the first half, which a neighbour's ring pass read: a benign data race).
#define PLEAT_POSED_POINT_FLOATS 8
// At most this many candidate body points per garment vertex (asset 1.2, BACA), and the index of an empty slot.
#define PLEAT_MAX_CONTACT_CANDIDATES 16
#define PLEAT_NO_CONTACT_CANDIDATE 0xFFFFu
// At most this many points in a body point's ring (BARG): the body mesh has at most 8 around a vertex.
#define PLEAT_MAX_POINT_RING 8
// The candidates almost as near as the nearest blend into one plane (body_contact.c says why): the share of the
// nearest squared distance, and a floor in metres, within which a candidate still counts.
#define PLEAT_CONTACT_BLEND_SHARE 0.1f
#define PLEAT_CONTACT_BLEND_M 0.001f
// How far a candidate's plane reaches (the full contact only): a vertex whose nearest usable candidate is within
// PLEAT_CONTACT_REACH_NEAR_M gets the whole push, one beyond PLEAT_CONTACT_REACH_FAR_M none, and in between a share
// that falls linearly in the squared distance (continuous, so a vertex never jumps). A plane centimetres away says
// little about where the body is: where the cloth had slid far from every candidate (the hem during a kick), pushing
// out of it drove vertices 4–5 cm into the belly, against 15 mm for the network alone (docs/accuracy.md).
#define PLEAT_CONTACT_REACH_NEAR_M 0.03f
#define PLEAT_CONTACT_REACH_FAR_M 0.05f
typedef void plPoseBodyPointsFn( float* posed, const float* shaped_points, const float* point_normals,
								 const uint16_t* skin_indices, const float* skin_weights, uint32_t influence_count,
								 const uint32_t* column_offsets, const float* skin_matrices, uint32_t joint_count,
								 const uint16_t* rings, uint32_t ring_count, uint32_t point_count, uint32_t p_begin,
								 uint32_t p_end );
// The posed body's normals at the anchorable points [p_begin, p_end) with a ring (asset 1.2, BARG; rings [P][R]: m ≥ 3
// point indices counter-clockwise from outside, then indices >= P): with d_i = a_{r_i} − a_p,
// n = Σ_i d_i × d_{(i+1) mod m} (the area-weighted normal of the closed fan), read from the posed positions that
// plPoseBodyPointsFn wrote for every point; then usable = |n| > 1e-12, n normalised. A point without a ring, or not
// anchorable, keeps its row. Writes only the normal and usable of the points in the range. ring_lanes (optional): the
// same rings in lanes (plRingLanes), which the AVX2 kernel reads (without them it runs the scalar kernel, the same bits).
typedef void plBodyPointNormalsFn( float* posed, uint32_t point_count, const uint16_t* rings, uint32_t ring_count,
								   const int32_t* ring_lanes, uint32_t p_begin, uint32_t p_end );
// The rings [P][R] in lanes for the AVX2 ring normals: [ceil(P / 8)][R][8] int32, slot s of point 8 b + i at [b][s][i]
// (INT32_MIN where the slot is empty: an index >= P, or a lane past P). The AVX2 kernel then loads a slot's eight
// indices and its mask at once; building them per call from the rings was a quarter of its work (asset.c builds them
// at load, plRingLanesCount int32 of them).
size_t plRingLanesCount( uint32_t point_count, uint32_t ring_count );
void plRingLanes( int32_t* dst, const uint16_t* rings, uint32_t ring_count, uint32_t point_count );
// The push for vertices [v_begin, v_end): of each vertex's usable candidates (candidates [N][C], an index >= P or
// PLEAT_NO_CONTACT_CANDIDATE = an empty slot; NULL = vertex v's point is v, C = 1), with m the nearest squared distance,
// w_c = max(0, (1 + PLEAT_CONTACT_BLEND_SHARE)·m + PLEAT_CONTACT_BLEND_M² − |x − a_c|²), a = Σ w_c a_c / Σ w_c and
// n = normalize(Σ w_c n_c) (slot order); d = (x − a)·n and if d < offset_m x ← x + r·(offset_m − d)·n with the reach
// r = plContactReach(m) with a candidate table, 1 without (a vertex with r = 0 is left as it is). row_offsets
// (optional): the same slots as posed rows' byte offsets in lanes (plContactRowOffsets), which the AVX2 kernel reads
// (without them it runs the scalar kernel, the same bits); an empty slot's is row P's, which posed then holds as zeros.
typedef void plBodyContactFn( float* positions, uint32_t position_stride_bytes, const float* posed, uint32_t point_count,
							  const uint16_t* candidates, uint32_t candidate_count, const uint32_t* row_offsets,
							  float offset_m, uint32_t v_begin, uint32_t v_end );
// The candidates [N][C] (NULL: vertex v's point is v, C = 1) as posed rows' byte offsets in lanes for the AVX2 push:
// [ceil(N / 8)][C][8] uint32, slot c of vertex 8 b + i at [b][c][i] = its point · PLEAT_POSED_POINT_FLOATS · 4, and an
// empty slot (an index >= P, or a lane past N) row P's, a zero row: usable 0, so no distance and no weight, as the
// scalar kernel's skip. A lane's row is then one load from posed + its offset; finding it per lane (the index, the
// empty test, the zero row) was a third of the push's instructions (asset.c builds them at load).
size_t plContactRowOffsetsCount( uint32_t vertex_count, uint32_t candidate_count );
void plContactRowOffsets( uint32_t* dst, const uint16_t* candidates, uint32_t candidate_count, uint32_t vertex_count,
						  uint32_t point_count );

// The fast body contact (pleat.h PLEAT_BODY_CONTACT_FAST, and asset 1.1's only one; body_contact_fast.c) for vertices
// [v_begin, v_end): vertex v's anchor is point v (the first N points of an asset whose first candidates are the
// vertices' own), posed on its own with its rest normal turned by its blended matrix; each vertex closer than offset_m
// to that plane moves out along its normal. Positions strided (bytes), anchors and normals [N][3], anchor skin [N][K]; a
// zero rest normal = no anchor; joint indices >= joint_count count as weight 0.
typedef void plBodyContactFastFn( float* positions, uint32_t position_stride_bytes, const float* shaped_anchors,
								  const float* anchor_normals, const uint16_t* anchor_skin_indices,
								  const float* anchor_skin_weights, uint32_t influence_count,
								  const uint32_t* column_offsets, const float* skin_matrices, uint32_t joint_count,
								  float offset_m, uint32_t v_begin, uint32_t v_end );

// m = Σ_k w_k M_{j_k} ([3][4] row-major), k in order, from K indices and weights; an index >= joint_count counts
// with weight 0 (the asset loader rejects it; never read out of bounds even so). The scalar skinning and body-contact
// kernels blend with this one loop.
static inline void plBlendJointMatrices( float m[12], const uint16_t* indices, const float* weights, uint32_t K,
										 const float* matrices, uint32_t joint_count )
{
	for ( int e = 0; e < 12; ++e )
	{
		m[e] = 0.0f;
	}
	for ( uint32_t k = 0; k < K; ++k )
	{
		uint32_t joint = indices[k];
		float w = weights[k];
		if ( joint >= joint_count )
		{
			joint = 0;
			w = 0.0f;
		}
		const float* mj = matrices + (size_t)joint * 12;
		for ( int e = 0; e < 12; ++e )
		{
			m[e] += w * mj[e];
		}
	}
}

// The full contact's reach at a vertex whose nearest usable candidate is sqrt(nearest) away: 1 within
// PLEAT_CONTACT_REACH_NEAR_M, 0 beyond PLEAT_CONTACT_REACH_FAR_M, linear in the squared distance between (the scalar
// and SIMD kernels and the shader compute it alike).
static inline float plContactReach( float nearest )
{
	const float near2 = PLEAT_CONTACT_REACH_NEAR_M * PLEAT_CONTACT_REACH_NEAR_M;
	const float far2 = PLEAT_CONTACT_REACH_FAR_M * PLEAT_CONTACT_REACH_FAR_M;
	float r = ( far2 - nearest ) / ( far2 - near2 );
	return r < 0.0f ? 0.0f : ( r > 1.0f ? 1.0f : r );
}

// The end of the body-contact test for one vertex x, shared by the scalar and AVX2 kernels of both contacts: n = (nx, ny, nz)
// normalised (a length ≤ 1e-12, a degenerate blend, leaves x as it is), d = (x − a)·n, and if d < offset_m
// x ← x + reach·(offset_m − d)·n (the fast contact's reach is 1, and a product with 1 changes no bit).
static inline void plPushOutOfAnchorPlane( float* x, float ax, float ay, float az, float nx, float ny, float nz,
										   float offset_m, float reach )
{
	float length = sqrtf( nx * nx + ny * ny + nz * nz );
	if ( !( length > 1e-12f ) )
	{
		return;
	}
	nx /= length;
	ny /= length;
	nz /= length;
	float d = ( x[0] - ax ) * nx + ( x[1] - ay ) * ny + ( x[2] - az ) * nz;
	if ( d < offset_m )
	{
		float push = ( offset_m - d ) * reach;
		x[0] += push * nx;
		x[1] += push * ny;
		x[2] += push * nz;
	}
}

struct plBatchKernels;

// A context's kernel table: the single-instance kernels, the batched twins plStepInstances runs (kernels_batch.h),
// and which set they are.
typedef struct plKernels
{
	plMatVecFn* mat_vec;
	plMatVecInt8Fn* mat_vec_int8;
	// The crowd's int8 layers where a set has a kernel that shares the weights between instances (both or neither;
	// NULL: each instance runs mat_vec_int8, the same bits).
	plMatMatInt8Fn* mat_mat_int8;
	plQuantiseInt8Fn* quantise_int8;
	plBlendShapesFn* blend_shapes;
	plSkinningFn* skinning;
	plFaceNormalsFn* face_normals;
	plNormalsGatherFn* normals_gather;
	plNormalsScatterFn* normals_scatter;
	plPoseBodyPointsFn* pose_body_points;
	plBodyPointNormalsFn* body_point_normals;
	plBodyContactFn* body_contact;
	plBodyContactFastFn* body_contact_fast;
	// The batched twins of the kernels above (each the same arithmetic per instance, kernels_batch.h): a static table
	// per set, never NULL once chosen.
	const struct plBatchKernels* batch;
	plKernelSet set; // which variants the table holds (plContext_GetKernelSet reports it)
} plKernels;

// The variants, declared through the kernel types so that their signatures cannot drift apart.
plMatVecFn plMatVec_Scalar;
plMatVecInt8Fn plMatVecInt8_Scalar;
plMatMatInt8Fn plMatMatInt8_Scalar;
plQuantiseInt8Fn plQuantiseInt8_Scalar;
plBlendShapesFn plBlendShapes_Scalar;
plSkinningFn plSkinning_Scalar;
plPoseBodyPointsFn plPoseBodyPoints_Scalar;
plBodyPointNormalsFn plBodyPointNormals_Scalar;
plBodyContactFn plBodyContact_Scalar;
plBodyContactFastFn plBodyContactFast_Scalar;
plFaceNormalsFn plFaceNormals_Scalar;
plNormalsGatherFn plNormalsGather_Scalar;
plNormalsScatterFn plNormalsScatter_Scalar;
#if defined( PLEAT_HAVE_AVX2 )
plMatVecFn plMatVec_Avx2;
plMatVecInt8Fn plMatVecInt8_Avx2;
void plQuantiseHeld_Avx2( void* held, const float* x, uint32_t count, const plLayer* layer );
// The int8 mat-vec with the dot-product instructions: AVX-VNNI (256-bit vpdpbusd, mlp_int8_avx2.c) and AVX-512 VNNI
// (mlp_int8_avx512.c), each compiled through a target attribute and only called where the CPU has it (plCpuHas*).
// Their shared frame (mlp_int8_avx2.c): the window quantised on the stack, then the rows four at a time through
// `quad`, which sums four rows' int8 products with q over `columns` (rows past the end repeat the last one). A FIRST
// input (12 bits, int16) takes the frame's own AVX2 products whatever `quad` is.
typedef void plInt8DotQuadFn( const int8_t* q, const int8_t* const rows[4], uint32_t columns, int32_t acc[4] );
void plMatVecInt8Rows_Avx2( float* out, const float* x, const plLayer* layer, const int8_t* weight, uint32_t stride,
							uint32_t col_begin, uint32_t col_end, uint32_t row_begin, uint32_t row_end,
							plInt8DotQuadFn* quad );
#if defined( PLEAT_HAVE_AVXVNNI )
plMatVecInt8Fn plMatVecInt8_AvxVnni;
int plCpuHasAvxVnni( void );
#endif
#if defined( PLEAT_HAVE_AVX512VNNI )
plMatVecInt8Fn plMatVecInt8_Avx512Vnni;
plMatMatInt8Fn plMatMatInt8_Avx512Vnni;
plQuantiseInt8Fn plQuantiseInt8_Avx512Vnni;
int plCpuHasAvx512Vnni( void );
#endif
plBlendShapesFn plBlendShapes_Avx2;
plSkinningFn plSkinning_Avx2;
plPoseBodyPointsFn plPoseBodyPoints_Avx2;
plBodyContactFn plBodyContact_Avx2;
plBodyContactFastFn plBodyContactFast_Avx2;
plBodyPointNormalsFn plBodyPointNormals_Avx2;
plFaceNormalsFn plFaceNormals_Avx2;
plNormalsGatherFn plNormalsGather_Avx2;
plNormalsScatterFn plNormalsScatter_Avx2;
#endif

// Fills the table with the widest kernel set up to max_isa that this build has and this CPU runs, and returns it
// (kernels->set): the scalar kernels always; AVX2 where the CPU has AVX2, FMA and F16C; AVX-512 (the AVX2 set, with
// the batched networks and blend shapes 16 wide) where it also has AVX-512 F/VL/BW/DQ and the OS saves its state.
// The one place the CPU is asked: a context calls it at creation, tests and benchmarks to build a set of their own.
plKernelSet plChooseKernels( plKernels* kernels, plKernelSet max_isa );
// Every int8 mat-vec this build has and this CPU runs, the scalar specification first, with a name each (for the
// tests that hold each one to the scalar kernel's bits, and benchmark reports); returns how many (≤ capacity).
// plChooseKernels takes the last: AVX-512 VNNI only in the AVX-512 set, as max_isa allows.
uint32_t plInt8MatVecVariants( plMatVecInt8Fn** kernels, const char** names, uint32_t capacity );

// float → IEEE half, round to nearest even (used by tests and tools).
uint16_t plFloatToHalf( float f );

// Σ_c w[c] x[c] for c < count from c = 0, one rounding per multiply and add, w the weights from element `base`: the
// row sum of plMatVec_Scalar, the specification (plMatMat_Scalar computes exactly this per instance).
static inline float plDotRowScalar( const float* x, const void* weight, int weight_fp16, size_t base, uint32_t count )
{
	float sum = 0.0f;
	if ( weight_fp16 )
	{
		const uint16_t* w = (const uint16_t*)weight + base;
		for ( uint32_t c = 0; c < count; ++c )
		{
			sum += plHalfToFloat( w[c] ) * x[c];
		}
	}
	else
	{
		const float* w = (const float*)weight + base;
		for ( uint32_t c = 0; c < count; ++c )
		{
			sum += w[c] * x[c];
		}
	}
	return sum;
}

#endif
