// The wide forms of the step's stages (step_lanes.h): what the single-stream forms in instance_step.c and
// instance_deform.c do to one instance, done to a group of instances of one asset with the batched kernels.
#include "step_lanes.h"

#include "jobs/jobs_batch.h"

#include <stdatomic.h>

plResult plRunNetworkLanes( plContextData* ctx, const plBatchKernels* kernels, const plAssetData* a,
							plInstanceData* const* insts, uint32_t count, int lp )
{
	plConstSpan in_spans[PLEAT_BATCH_MAX];
	plSpan out_spans[PLEAT_BATCH_MAX];
	plSpan scratch_spans[PLEAT_BATCH_MAX];
	for ( uint32_t m = 0; m < count; ++m )
	{
		plInstanceData* inst = insts[m];
		in_spans[m] = lp ? plMakeConstSpan( inst->x, a->input_count, 4 )
						 : plMakeConstSpan( inst->next_latent, a->latent_count, 4 );
		out_spans[m] = lp ? plMakeSpan( inst->y, a->latent_count, 4 )
						  : plMakeSpan( inst->next_weights, a->blend_count, 4 );
		scratch_spans[m] = plMakeSpan( inst->mlp_scratch, inst->mlp_scratch_count, 4 );
	}
	plMlpBatchJob job = { lp ? a->lp : a->dec,
						  lp ? a->lp_layer_count : a->dec_layer_count,
						  lp ? a->lp_activation : a->dec_activation,
						  count,
						  in_spans,
						  out_spans,
						  scratch_spans,
						  kernels,
						  &ctx->runner,
						  NULL,
						  0,
						  ctx->kernels.mat_vec_int8,
						  ctx->kernels.mat_mat_int8,
						  ctx->kernels.quantise_int8 };
	int slot = -1;
	// the transposed chain's scratch, or the int8 layers' held inputs (without it the job runs the row-tile kernels,
	// or each instance through the single int8 kernel: the same results)
	size_t floats = kernels->mat_mat_lanes != NULL ? plMlpBatchLanesFloats( job.layers, job.layer_count, count ) : 0;
	size_t held = job.mat_mat_int8 != NULL ? plMlpBatchHeldFloats( job.layers, job.layer_count, count ) : 0;
	floats = held > floats ? held : floats;
	if ( floats > 0 )
	{
		slot = plClaimBatchScratch( ctx, floats );
		if ( slot >= 0 )
		{
			job.lanes = ctx->batch_scratch[slot];
			job.lanes_floats = floats;
		}
	}
	plResult r = plMlpBatchJob_Run( &job );
	if ( slot >= 0 )
	{
		plReleaseBatchScratch( ctx, slot );
	}
	return r == PLEAT_RESULT_OK ? PLEAT_RESULT_OK : PLEAT_RESULT_INTERNAL_ERROR;
}

typedef struct plBlendLanesTask
{
	const plBatchKernels* kernels;
	const plAssetData* asset;
	plInstanceData* const* insts;
	const float* weights[PLEAT_BATCH_MAX]; // each instance's, as the kernels take them (plBlendKernelWeights)
	uint32_t count;
	atomic_int result; // a worker's job error, PLEAT_RESULT_OK otherwise
} plBlendLanesTask;

static void plBlendLanesRange( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plBlendLanesTask* t = (plBlendLanesTask*)context;
	const plAssetData* a = t->asset;
	plConstSpan templates[PLEAT_BATCH_MAX], weights[PLEAT_BATCH_MAX];
	plSpan outputs[PLEAT_BATCH_MAX];
	for ( uint32_t m = 0; m < t->count; ++m )
	{
		plInstanceData* inst = t->insts[m];
		templates[m] = plMakeConstSpan( inst->shaped_template, a->vertex_count, 12 );
		weights[m] = plMakeConstSpan( t->weights[m], a->blend_count, 4 );
		outputs[m] = plMakeSpan( inst->deformed, a->vertex_count, 12 );
	}
	plBlendShapesBatchJob job = { t->count,       templates, weights, outputs, a->blend_shapes,
								  a->vertex_count, begin,     end,     t->kernels };
	if ( plBlendShapesBatchJob_Run( &job ) != PLEAT_RESULT_OK )
	{
		atomic_store_explicit( &t->result, (int)PLEAT_RESULT_INTERNAL_ERROR, memory_order_relaxed );
	}
}

plResult plBlendLanes( const plBatchKernels* kernels, const plAssetData* a, plInstanceData* const* insts,
					   uint32_t count, const plTaskRunner* runner )
{
	plBlendLanesTask task;
	task.kernels = kernels;
	task.asset = a;
	task.insts = insts;
	task.count = count;
	if ( count > PLEAT_BATCH_MAX )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT; // (the groups are at most that; the batch job refuses more too)
	}
	for ( uint32_t m = 0; m < count; ++m )
	{
		task.weights[m] = plBlendKernelWeights( insts[m], insts[m]->next_weights ); // once, before the ranges
	}
	atomic_init( &task.result, (int)PLEAT_RESULT_OK );
	plRunTask( runner, plBlendLanesRange, a->vertex_count, 256, &task );
	return (plResult)atomic_load_explicit( &task.result, memory_order_relaxed );
}

plResult plGeometryLanes( plContextData* ctx, const plBatchKernels* kernels, const plAssetData* a, int fast_contact,
						  plInstanceData* const* insts, const float* const* in, float* const* positions,
						  float* const* normals, uint32_t count )
{
	const float* matrices[PLEAT_BATCH_MAX] = { NULL }; // (all of count filled below; GCC's scalar build cannot tell)
	// The lanes with body contact, by which contact they run (plRunsFastContact): the fast one and the full one.
	plInstanceData* contact_insts[2][PLEAT_BATCH_MAX];
	float* contact_positions[2][PLEAT_BATCH_MAX];
	const float* contact_points[2][PLEAT_BATCH_MAX];
	const float* contact_matrices[2][PLEAT_BATCH_MAX];
	float contact_offsets[2][PLEAT_BATCH_MAX];
	uint32_t contact_count[2] = { 0, 0 };
	enum
	{
		FAST = 0,
		FULL = 1
	};
	for ( uint32_t k = 0; k < count; ++k )
	{
		matrices[k] = insts[k]->next_skin_matrices;
		if ( insts[k]->body_contact )
		{
			int kind = plRunsFastContact( insts[k], fast_contact ) ? FAST : FULL;
			uint32_t i = contact_count[kind]++;
			contact_insts[kind][i] = insts[k];
			contact_positions[kind][i] = positions[k];
			contact_points[kind][i] = insts[k]->shaped_anchors;
			contact_matrices[kind][i] = matrices[k];
			contact_offsets[kind][i] = insts[k]->body_contact_offset_m;
		}
	}
	kernels->skinning_batch( positions, in, count, a->skin_indices, a->skin_weights, a->influence_count, matrices,
							 a->joint_count, 0, a->vertex_count );
	// What plDeformCpu runs between skinning and normals, with each lane getting its lone step's bits. The fast
	// contact in lanes (its batched kernel gives each lane the single kernel's bits).
	if ( contact_count[FAST] > 0 )
	{
		kernels->body_contact_fast_batch( contact_positions[FAST], contact_points[FAST], contact_offsets[FAST],
										  contact_count[FAST], a->body_anchor_normals, a->body_anchor_skin_indices,
										  a->body_anchor_skin_weights, a->body_anchor_influence_count,
										  contact_matrices[FAST], a->joint_count, 0, a->vertex_count );
	}
	// The full contact: in lanes where the set has the kernel and a scratch block is free, else instance by instance.
	plResult r = PLEAT_RESULT_OK;
	int contact_slot = contact_count[FULL] > 1 && kernels->body_contact_batch != NULL
						   ? plClaimBatchScratch( ctx, plBodyContactBatchScratchFloats( a->body_point_count, kernels->geometry_lanes ) )
						   : -1;
	if ( contact_slot >= 0 )
	{
		kernels->body_contact_batch( contact_positions[FULL], contact_points[FULL], contact_offsets[FULL],
									 contact_count[FULL], a->body_anchor_normals, a->body_anchor_skin_indices,
									 a->body_anchor_skin_weights, a->body_anchor_influence_count,
									 contact_matrices[FULL], a->joint_count, a->body_point_count,
									 a->body_anchor_candidates, a->body_anchor_candidate_count, a->body_anchor_ring,
									 a->body_anchor_ring_count, a->vertex_count, ctx->batch_scratch[contact_slot] );
		plReleaseBatchScratch( ctx, contact_slot );
	}
	else
	{
		for ( uint32_t i = 0; i < contact_count[FULL] && r == PLEAT_RESULT_OK; ++i )
		{
			r = plRunBodyContact( contact_insts[FULL][i], contact_positions[FULL][i], contact_matrices[FULL][i], 0 );
		}
	}
	if ( r != PLEAT_RESULT_OK )
	{
		return PLEAT_RESULT_INTERNAL_ERROR; // the jobs only refuse spans the instance did not build
	}
	int slot = plClaimBatchScratch( ctx, plNormalsBatchScratchFloats( a->vertex_count, kernels->geometry_lanes ) );
	if ( slot < 0 )
	{
		// No scratch free: each lane's own normals (the single step's kernels, the same bits).
		for ( uint32_t k = 0; k < count && r == PLEAT_RESULT_OK; ++k )
		{
			r = plRunNormals( insts[k], positions[k], normals[k], NULL );
		}
		return r;
	}
	kernels->normals_batch( normals, (const float* const*)positions, count, a->vertex_count, a->faces, a->face_count,
							ctx->batch_scratch[slot] );
	plReleaseBatchScratch( ctx, slot );
	return PLEAT_RESULT_OK;
}
