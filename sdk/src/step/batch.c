// plStepInstances: many instances stepped in one call. Instances of the same asset (and, in a GPU mode, one batch of
// dispatches) are gathered into groups of up to PLEAT_BATCH_MAX (PLEAT_GPU_GROUP_MAX for the GPU backend's), and each
// group runs the step's one list of stages
// (step.c) with the wide forms: f_LP and f_dec as matrix-matrix products, the blend as a small GEMM, skinning, body
// contact and normals with 8 or 16 instances per vector — each weight and blend shape read once per group instead of
// once per instance. The wide forms do per instance exactly the single-stream forms' arithmetic, so every instance
// ends bit-identical to stepping it alone (test_batch_step_matches_single). An instance on the ONNX Runtime backend,
// or with no other instance of its asset in the call, is a group of one: the single step itself.
#include "step.h"

#include <stdio.h>
#include <string.h>

// Instances looked at together when forming groups (a bitmap of this many bits on the stack).
#define PLEAT_BATCH_WINDOW 1024

// ---- the call ----

// The instance behind a handle of this context, or NULL.
static plInstanceData* plLookup( plContext context, plInstance handle )
{
	if ( handle.context.index1 != context.index1 || handle.context.generation != context.generation )
	{
		return NULL;
	}
	return plGetInstanceData( handle );
}

static int plBatchable( const plInstanceData* inst )
{
	return inst->ort_lp == NULL && inst->ort_dec == NULL;
}

// Non-zero if inst can join a group that first leads: the same asset, and both on the CPU or both in a GPU mode that
// can share one batch of dispatches.
static int plSameGroup( const plInstanceData* first, const plInstanceData* inst )
{
	if ( inst->asset != first->asset || !plBatchable( inst ) )
	{
		return 0;
	}
	if ( first->gl == NULL || inst->gl == NULL )
	{
		return first->gl == NULL && inst->gl == NULL;
	}
	return plGlDeformer_CanBatch( first->gl, inst->gl );
}

typedef struct plBatchOutcome
{
	uint32_t error_index, note_index; // lowest list index with an error / a note (UINT32_MAX: none)
	plResult error, note;
} plBatchOutcome;

static void plRecord( plBatchOutcome* outcome, plResult* out_results, uint32_t index, plResult r )
{
	if ( out_results != NULL )
	{
		out_results[index] = r;
	}
	if ( r < 0 && index < outcome->error_index )
	{
		outcome->error_index = index;
		outcome->error = r;
	}
	else if ( r > 0 && index < outcome->note_index )
	{
		outcome->note_index = index;
		outcome->note = r;
	}
}

plResult plStepInstances( plContext context, const plInstance* instances, const plFrameInput* inputs,
						  const plStepOutput* outputs, plResult* out_results, uint32_t count )
{
	plContextData* ctx = plGetContext( context );
	if ( ctx == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	if ( count == 0 )
	{
		return PLEAT_RESULT_OK;
	}
	if ( instances == NULL || inputs == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	int batched_kernels = ctx->kernels.batch != NULL; // the context's, chosen at its creation
	plBatchOutcome outcome = { UINT32_MAX, UINT32_MAX, PLEAT_RESULT_OK, PLEAT_RESULT_OK };
	plStepEntry entries[PLEAT_BATCH_MAX];
	plStepGroup group;
	for ( uint32_t w0 = 0; w0 < count; w0 += PLEAT_BATCH_WINDOW )
	{
		uint32_t w1 = count - w0 > PLEAT_BATCH_WINDOW ? w0 + PLEAT_BATCH_WINDOW : count;
		uint8_t done[PLEAT_BATCH_WINDOW / 8];
		memset( done, 0, sizeof( done ) );
#define PLEAT_DONE_( i ) ( done[( ( i ) - w0 ) >> 3] & ( 1u << ( ( ( i ) - w0 ) & 7u ) ) )
#define PLEAT_MARK_( i ) ( done[( ( i ) - w0 ) >> 3] |= (uint8_t)( 1u << ( ( ( i ) - w0 ) & 7u ) ) )
		for ( uint32_t s = w0; s < w1; ++s )
		{
			if ( PLEAT_DONE_( s ) )
			{
				continue;
			}
			PLEAT_MARK_( s );
			plInstanceData* first = plLookup( context, instances[s] );
			if ( first == NULL )
			{
				char detail[64];
				snprintf( detail, sizeof( detail ), "at instances[%u] is stale or of another context", s );
				plLogStaleInstance( ctx, instances[s], __func__, detail );
				plRecord( &outcome, out_results, s, PLEAT_RESULT_INVALID_HANDLE );
				continue;
			}
			// A group: this instance and the next unprocessed ones of the same asset, each at most once (a second
			// listing of an instance waits for a later group, so it is stepped after the first, in list order). The
			// GPU backend's groups take up to PLEAT_GPU_GROUP_MAX instances in a scratch block (one set of dispatches
			// for a whole crowd window); without a free block, PLEAT_BATCH_MAX, as every other group.
			uint32_t stack_indices[PLEAT_BATCH_MAX];
			uint32_t* indices = stack_indices;
			uint32_t room = batched_kernels && plBatchable( first ) ? PLEAT_BATCH_MAX : 1;
			int block = room > 1 && plGlDeformer_HasNetworks( first->gl )
							? plClaimBatchScratch( ctx, PLEAT_GPU_GROUP_FLOATS )
							: -1;
			if ( block >= 0 )
			{
				plStepGroup_InitGpu( &group, ctx, first->asset, ctx->batch_scratch[block], &ctx->runner, __func__,
									 &indices );
				room = PLEAT_GPU_GROUP_MAX;
			}
			else
			{
				plStepGroup_Init( &group, ctx, first->asset, entries, 1, &ctx->runner, __func__ );
			}
			for ( uint32_t t = s; t < w1 && group.count < room; ++t )
			{
				plInstanceData* inst = t == s ? first : ( PLEAT_DONE_( t ) ? NULL : plLookup( context, instances[t] ) );
				if ( inst == NULL || ( t != s && !plSameGroup( first, inst ) ) )
				{
					continue;
				}
				int duplicate = 0;
				for ( uint32_t k = 0; k < group.count && !duplicate; ++k )
				{
					duplicate = group.entries[k].inst == inst;
				}
				if ( duplicate )
				{
					continue;
				}
				PLEAT_MARK_( t );
				indices[group.count] = t;
				plStepGroup_Add( &group, inst, &inputs[t], outputs != NULL ? &outputs[t] : NULL );
			}
			// A group of one takes the single-stream forms (their kernels stream a lone instance's weights faster
			// than the wide ones, which are built for many): the single step itself.
			plRunStepGroup( &group );
			for ( uint32_t k = 0; k < group.count; ++k )
			{
				plRecord( &outcome, out_results, indices[k], group.entries[k].result );
			}
			if ( block >= 0 )
			{
				plReleaseBatchScratch( ctx, block );
			}
		}
#undef PLEAT_DONE_
#undef PLEAT_MARK_
	}
	return outcome.error_index != UINT32_MAX ? outcome.error : outcome.note;
}
