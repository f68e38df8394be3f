// Internal: the batched twins of the MLP and blend-shape kernels (kernels.h), for plStepInstances (batch.c). Many
// instances of one asset are evaluated together, so a weight row or a blend-shape tile read from memory once serves
// every instance of the batch: the mat-vec becomes a matrix-matrix product, the blend a small GEMM.
//
// Bit-identical by construction: each batched kernel is the twin of one single-instance kernel and performs, for every
// (instance, output) pair, exactly the arithmetic of that kernel — the same operations on the same operands in the
// same order, only interleaved with other instances' (independent) operations:
//     plMatMat_Scalar          ↔ plMatVec_Scalar         one float sum per row, c ascending, then + bias
//     plMatMat_Avx2            ↔ plMatVec_Avx2           two 8-wide FMA chains (even / odd 8-blocks of each 16-step),
//                                                         the 8-wide step into the first, their sum, the horizontal
//                                                         sum, a scalar fmaf tail, then + bias
//     plBlendShapesBatch_Scalar ↔ plBlendShapes_Scalar   per element base, then += w_j · D_j, j ascending (two roundings)
//     plBlendShapesBatch_Avx2   ↔ plBlendShapes_Avx2     per element base, then fma(w_j, D_j, ·), j ascending
//     plSkinningBatch_*         ↔ plSkinning_*           per vertex the blended matrix as an FMA chain over k (AVX2)
//                                                         or mul + add (scalar), then the same transform expression
//     plBodyContactFastBatch_*  ↔ plBodyContactFast_*    the anchor's blended matrix, posed anchor and normal as
//                                                         skinning's, then the same length, plane distance and push
//     plNormalsBatch_*          ↔ plNormalsScatter_*     per face the same cross product (separate roundings), per
//                                                         vertex the same ascending-face sum and normalisation
// The _Avx512 kernels (AVX-512 F/VL/BW/DQ, chosen at run time when the CPU has them) are further twins of the _Avx2
// single-instance kernels — a 16-wide FMA whose low and high halves are plMatVec_Avx2's even and odd chains, sixteen
// instances per vector in the lanes form, 16-wide blend tiles — never of a single-instance AVX-512 kernel: a context's
// single-instance kernels stay the AVX2 set (PLEAT_KERNEL_SET_AVX512 names that pairing), and a batch on an AVX-512 CPU
// gives exactly what they give. The AVX-512 set keeps the 8-lane AVX2 skinning, fast body contact and normals (the
// full contact runs per instance, plRunBodyContact).
// test_batched_kernels_match_single checks each pair bit for bit, and every variant against the scalar specification.
#ifndef PLEAT_KERNELS_BATCH_H
#define PLEAT_KERNELS_BATCH_H
#include "kernels.h"

#include <stddef.h>
#include <stdint.h>

// The most instances one batched kernel call takes (the job and plStepInstances cut larger groups).
#define PLEAT_BATCH_MAX 64

// out[b][r] = bias[r] + Σ_c W[r][c] · x[b][c] over columns [col_begin, col_end) (plMatVecFn's window) for rows
// [row_begin, row_end) and b < batch_count; W is [rows][in_count] row-major, fp32 or fp16 (read once per call from
// memory, then from cache for every b).
typedef void plMatMatFn( float* const* out, const float* const* x, uint32_t batch_count, const void* weight,
						 int weight_fp16, const float* bias, uint32_t in_count, uint32_t col_begin, uint32_t col_end,
						 uint32_t row_begin, uint32_t row_end );
// out[b][v] = base[b][v] + Σ_j weights[b][j] · shapes[j][v] for vertices [v_begin, v_end) and b < batch_count;
// shapes is [D][N][3] (plShapeElement's values); out[b] may not alias base[b].
typedef void plBlendShapesBatchFn( float* const* out, const float* const* base, const float* const* weights,
								   uint32_t batch_count, const plBlendShapes* shapes, uint32_t blend_count,
								   uint32_t vertex_count, uint32_t v_begin, uint32_t v_end );

// The lanes form of a mat-mat (sixteen instances per vector): yt[g][r][l] = bias[r] + Σ_c W[r][c] · xt[g][c][l] over
// columns [col_begin, col_end) for rows [row_begin, row_end) of every lane group g < group_count, each (r, instance)
// with its single-instance twin's arithmetic; xt is [group_count][in_count][16], yt [group_count][out_count][16], both
// 64-byte aligned (lanes past a batch's instances hold anything finite, and their results are not used). Row r's
// window W[r][col_begin..col_end) starts at element r · weight_stride of `window`: the layer in place (window = the
// weights + col_begin, stride in_count) or its packed copy (plLayer.packed, stride packed_width). fp16 weights:
// col_end - col_begin <= 1024.
typedef void plMatMatLanesFn( float* yt, const float* xt, uint32_t group_count, const void* window,
							  size_t weight_stride, int weight_fp16, const float* bias, uint32_t in_count,
							  uint32_t out_count, uint32_t col_begin, uint32_t col_end, uint32_t row_begin,
							  uint32_t row_end );
#define PLEAT_LANES 16
#define PLEAT_LANES_MAX_FP16_COLUMNS 1024

// Linear blend skinning of batch_count instances of one mesh for vertices [v_begin, v_end): out[b][v] =
// (Σ_k w_vk M_b,{j_vk}) · (in[b][v], 1), in and out packed [N][3] (stride 12), skin_matrices[b] [J][3][4]; joint indices
// >= joint_count count as weight 0, as in plSkinningFn.
typedef void plSkinningBatchFn( float* const* out, const float* const* in, uint32_t batch_count,
								const uint16_t* skin_indices, const float* skin_weights, uint32_t influence_count,
								const float* const* skin_matrices, uint32_t joint_count, uint32_t v_begin,
								uint32_t v_end );
// Body contact of batch_count instances of one mesh for vertices [v_begin, v_end): what plBodyContactFastFn does to each
// instance (positions[b] packed [N][3], moved in place; shaped_anchors[b] its anchors [N][3]; offsets_m[b] its
// clearance; skin_matrices[b] [J][3][4]); the asset's anchor normals and skinning are shared.
typedef void plBodyContactFastBatchFn( float* const* positions, const float* const* shaped_anchors, const float* offsets_m,
								   uint32_t batch_count, const float* anchor_normals,
								   const uint16_t* anchor_skin_indices, const float* anchor_skin_weights,
								   uint32_t influence_count, const float* const* skin_matrices, uint32_t joint_count,
								   uint32_t v_begin, uint32_t v_end );
// The full body contact of batch_count (<= 8) instances of one mesh: what plPoseBodyPointsFn, plBodyPointNormalsFn
// (rings may be NULL) and plBodyContactFn do to each instance (positions[b] packed [N][3], moved in place;
// shaped_points[b] its points [P][3]; offsets_m[b] its clearance; skin_matrices[b] [J][3][4]); the asset's points,
// candidates and rings are shared. scratch: [P][8][lanes] floats (plBodyContactBatchScratchFloats with the set's
// geometry_lanes), 64-byte aligned.
typedef void plBodyContactBatchFn( float* const* positions, const float* const* shaped_points, const float* offsets_m,
								   uint32_t batch_count, const float* point_normals, const uint16_t* skin_indices,
								   const float* skin_weights, uint32_t influence_count,
								   const float* const* skin_matrices, uint32_t joint_count, uint32_t point_count,
								   const uint16_t* candidates, uint32_t candidate_count, const uint16_t* rings,
								   uint32_t ring_count, uint32_t vertex_count, float* scratch );
#define plBodyContactBatchScratchFloats( point_count, lanes ) ( (size_t)( point_count ) * 8 * ( lanes ) )
// Vertex normals of batch_count instances of one mesh, all vertices: what plNormalsScatterFn gives each instance
// (positions[b] and normals[b] packed [N][3]). scratch: [plNormalsBatchScratchFloats(N, batch lanes)] floats, 64-byte
// aligned, shared by the call (the SIMD twins keep the positions and the sums there with the instances as lanes).
typedef void plNormalsBatchFn( float* const* normals, const float* const* positions, uint32_t batch_count,
							   uint32_t vertex_count, const uint32_t* faces, uint32_t face_count, float* scratch );

typedef struct plBatchKernels
{
	plMatMatFn* mat_mat;
	plMatMatLanesFn* mat_mat_lanes; // NULL where the set has none (the MLP job then runs mat_mat)
	plBlendShapesBatchFn* blend_shapes_batch;
	plSkinningBatchFn* skinning_batch;
	plBodyContactFastBatchFn* body_contact_fast_batch;
	plBodyContactBatchFn* body_contact_batch; // NULL where the set has none (each instance then runs it alone)
	plNormalsBatchFn* normals_batch;
	uint32_t geometry_lanes; // instances per geometry call (a lane group): what body_contact_batch fills its registers
	                         // with, and skinning_batch / normals_batch take in one call (1 = scalar)
	const char* isa;         // the instruction sets of these kernels, for benchmark reports
} plBatchKernels;

// Floats of scratch plNormalsBatchFn needs for N vertices and up to `lanes` instances per call: the positions and the
// sums, [N][3][lanes] each, plus padding; for the scalar kernel (lanes = 1) the scatter's [N][4] sums.
size_t plNormalsBatchScratchFloats( uint32_t vertex_count, uint32_t lanes );

plMatMatFn plMatMat_Scalar;
void plBlendShapesBatch_Scalar( float* const* out, const float* const* base, const float* const* weights,
								uint32_t batch_count, const plBlendShapes* shapes, uint32_t blend_count,
								uint32_t vertex_count, uint32_t v_begin, uint32_t v_end );
plSkinningBatchFn plSkinningBatch_Scalar;
plBodyContactFastBatchFn plBodyContactFastBatch_Scalar;
plNormalsBatchFn plNormalsBatch_Scalar;
#if defined( PLEAT_HAVE_AVX2 )
plSkinningBatchFn plSkinningBatch_Avx2;
plBodyContactFastBatchFn plBodyContactFastBatch_Avx2;
plBodyContactBatchFn plBodyContactBatch_Avx2;
plNormalsBatchFn plNormalsBatch_Avx2;
#endif
#if defined( PLEAT_HAVE_AVX512 )
plMatMatFn plMatMat_Avx512;
plMatMatLanesFn plMatMatLanes_Avx512;
plBlendShapesBatchFn plBlendShapesBatch_Avx512;
plBodyContactBatchFn plBodyContactBatch_Avx512; // 16 instances per call
#endif
// The AVX-512 kernels write their register tiles for constant sizes and instantiate them per instance count through a
// switch: CASE( size, n ) expands to `case n:` and the call for that count, n = 1..6 or 1..8.
#define PLEAT_TILE_CASES_1_TO_6( CASE, size )                                                                          \
	CASE( size, 1 ) CASE( size, 2 ) CASE( size, 3 ) CASE( size, 4 ) CASE( size, 5 ) CASE( size, 6 )
#define PLEAT_TILE_CASES_1_TO_8( CASE, size ) PLEAT_TILE_CASES_1_TO_6( CASE, size ) CASE( size, 7 ) CASE( size, 8 )
#if defined( PLEAT_HAVE_AVX2 )
plMatMatFn plMatMat_Avx2;
void plBlendShapesBatch_Avx2( float* const* out, const float* const* base, const float* const* weights,
							  uint32_t batch_count, const plBlendShapes* shapes, uint32_t blend_count,
							  uint32_t vertex_count, uint32_t v_begin, uint32_t v_end );
#endif

// The batched twins of one kernel set (plChooseKernels puts them in the context's table): each entry matches the
// single-instance kernel in the same slot of that set, so a batch gives what stepping each instance alone gives.
// PLEAT_KERNEL_SET_AVX512's are the AVX2 set's with the AVX-512 networks and blend. NULL for a set this build lacks.
const plBatchKernels* plBatchKernelsOf( plKernelSet set );
// Non-zero if this build has the AVX-512 batched kernels and this CPU (and OS) runs them.
int plCpuHasAvx512Batch( void );

#endif
