// Internal: the wide forms of the step's stages, for a group of instances of one asset (step.c picks them for a
// crowd): f_LP and f_dec as matrix-matrix products and the blend as a small GEMM (jobs_batch.h), so each weight and
// blend shape is read once per group instead of once per instance; skinning, body contact and normals with the
// instances as vector lanes. The batched kernels do per instance exactly the single kernels' arithmetic
// (kernels_batch.h), so every instance gets the bits of its single-stream form (test_batch_step_matches_single).
#ifndef PLEAT_STEP_LANES_H
#define PLEAT_STEP_LANES_H
#include "instance/instance.h"
#include "kernels/kernels_batch.h"

#include <stdint.h>

// f_LP (lp non-zero: inst->x → inst->y) or f_dec (inst->next_latent → inst->next_weights) of count (<=
// PLEAT_BATCH_MAX) instances of a. PLEAT_RESULT_INTERNAL_ERROR if the job rejected the spans (a defect of the SDK).
plResult plRunNetworkLanes( plContextData* ctx, const plBatchKernels* kernels, const plAssetData* a,
							plInstanceData* const* insts, uint32_t count, int lp );
// T_def = shaped template + Σ_j w_j D_j (inst->next_weights → inst->deformed) of count instances of a, the vertices
// split over runner's workers. PLEAT_RESULT_INTERNAL_ERROR as plRunNetworkLanes.
plResult plBlendLanes( const plBatchKernels* kernels, const plAssetData* a, plInstanceData* const* insts,
					   uint32_t count, const plTaskRunner* runner );
// Skinning, body contact and normals of count lanes (count <= the kernels' geometry_lanes) on this thread: in[k]
// skinned with insts[k]'s next_skin_matrices into positions[k], the body contact plDeformCpu would run (fast_contact:
// force the fast one, plRunsFastContact), normals into normals[k]. Per lane the single kernels' operations in the same
// order, so every lane gets its single-stream bits. Where no scratch block is free, the full contact and the normals
// run lane by lane (the single kernels, the same bits). PLEAT_RESULT_INTERNAL_ERROR if a job rejected its spans.
plResult plGeometryLanes( plContextData* ctx, const plBatchKernels* kernels, const plAssetData* a, int fast_contact,
						  plInstanceData* const* insts, const float* const* in, float* const* positions,
						  float* const* normals, uint32_t count );

#endif
