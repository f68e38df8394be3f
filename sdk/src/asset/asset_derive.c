// What the load derives from an asset for the context's kernels (asset_derive.h): tables the AVX2 kernels read
// instead of working them out per call, and the crowd's scratch need.
#include "asset_derive.h"

#include "jobs/jobs.h"
#include "jobs/jobs_batch.h"
#include "kernels/kernels_batch.h"

// The next `bytes` of a derived block (NULL for none), each part starting on a 64-byte line.
static void* plTakeDerived( uint8_t** cursor, size_t bytes )
{
	if ( bytes == 0 )
	{
		return NULL;
	}
	void* part = *cursor;
	*cursor += plAlign64( bytes );
	return part;
}

// An int8 layer's weight_sums: row r's Σ w over its block's column window (kernels.h plLayer), what a HIDDEN
// input's held q − 128 and the crowd's biased inputs leave out of the sum.
static void plInt8RowSums( const plLayer* l, int32_t* sums )
{
	plLayerBlock blocks[PLEAT_MAX_LAYER_BLOCKS];
	uint32_t block_count = plLayerBlocks( l, blocks );
	const int8_t* weight = (const int8_t*)l->weight;
	for ( uint32_t b = 0; b < block_count; ++b )
	{
		for ( uint32_t r = blocks[b].row_begin; r < blocks[b].row_end; ++r )
		{
			int32_t sum = 0;
			for ( uint32_t c = blocks[b].col_begin; c < blocks[b].col_end; ++c )
			{
				sum += weight[(size_t)r * l->in_count + c];
			}
			sums[r] = sum;
		}
	}
}

static size_t plInt8WeightSumBytes( const plLayer* l )
{
	return l->weight_int8 ? l->out_count * sizeof( int32_t ) : 0;
}

// What the load derives for the kernels, in one block: the single step's packed copies of the networks' block layers
// (kernels.h plLayer.packed), the int8 layers' row sums, the body's rings in lanes for the AVX2 ring normals (plRingLanes), the contact
// candidates as posed rows' offsets for the AVX2 push (plContactRowOffsets) and the garment's and body points' skin
// indices as column-block offsets for the AVX2 skinning and posing (plSkinColumnOffsets).
plResult plDeriveKernelData( plContextData* ctx, plAssetData* asset )
{
	uint32_t layer_count = asset->lp_layer_count + asset->dec_layer_count;
	uint32_t C = asset->body_anchor_candidates != NULL ? asset->body_anchor_candidate_count : 1;
	size_t N = asset->vertex_count, P = asset->body_point_count;
	size_t ring_bytes = asset->body_anchor_ring != NULL
							? plRingLanesCount( asset->body_point_count, asset->body_anchor_ring_count ) * sizeof( int32_t )
							: 0;
	size_t row_bytes = P > 0 ? plContactRowOffsetsCount( asset->vertex_count, C ) * sizeof( uint32_t ) : 0;
	size_t skin_count = N * asset->influence_count, body_count = P * asset->body_anchor_influence_count;
	size_t total = plAlign64( ring_bytes ) + plAlign64( row_bytes ) + plAlign64( skin_count * sizeof( uint32_t ) ) +
				   plAlign64( body_count * sizeof( uint32_t ) );
	for ( uint32_t i = 0; i < layer_count; ++i )
	{
		const plLayer* l = i < asset->lp_layer_count ? &asset->lp[i] : &asset->dec[i - asset->lp_layer_count];
		total += plAlign64( plPackedLayerBytes( l ) ) + plAlign64( plInt8WeightSumBytes( l ) );
	}
	if ( total == 0 )
	{
		return PLEAT_RESULT_OK;
	}
	uint8_t* cursor = (uint8_t*)plAlloc( &ctx->allocator, total, 64 );
	if ( cursor == NULL )
	{
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	asset->derived_block = cursor;
	asset->derived_size = total;
	for ( uint32_t i = 0; i < layer_count; ++i )
	{
		plLayer* l = i < asset->lp_layer_count ? &asset->lp[i] : &asset->dec[i - asset->lp_layer_count];
		void* copy = plTakeDerived( &cursor, plPackedLayerBytes( l ) );
		if ( copy != NULL )
		{
			plPackLayer( l, copy );
		}
		int32_t* sums = (int32_t*)plTakeDerived( &cursor, plInt8WeightSumBytes( l ) );
		if ( sums != NULL )
		{
			plInt8RowSums( l, sums );
			l->weight_sums = sums;
		}
	}
	int32_t* ring_lanes = (int32_t*)plTakeDerived( &cursor, ring_bytes );
	if ( ring_lanes != NULL )
	{
		plRingLanes( ring_lanes, asset->body_anchor_ring, asset->body_anchor_ring_count, asset->body_point_count );
		asset->body_anchor_ring_lanes = ring_lanes;
	}
	uint32_t* row_offsets = (uint32_t*)plTakeDerived( &cursor, row_bytes );
	if ( row_offsets != NULL )
	{
		plContactRowOffsets( row_offsets, asset->body_anchor_candidates, C, asset->vertex_count,
							 asset->body_point_count );
		asset->body_contact_row_offsets = row_offsets;
	}
	uint32_t* skin_offsets = (uint32_t*)plTakeDerived( &cursor, skin_count * sizeof( uint32_t ) );
	if ( skin_offsets != NULL )
	{
		plSkinColumnOffsets( skin_offsets, asset->skin_indices, skin_count, asset->joint_count );
		asset->skin_column_offsets = skin_offsets;
	}
	uint32_t* body_offsets = (uint32_t*)plTakeDerived( &cursor, body_count * sizeof( uint32_t ) );
	if ( body_offsets != NULL )
	{
		plSkinColumnOffsets( body_offsets, asset->body_anchor_skin_indices, body_count, asset->joint_count );
		asset->body_anchor_column_offsets = body_offsets;
	}
	return PLEAT_RESULT_OK;
}

// Floats of a context scratch block plStepInstances needs for the asset with the context's batched kernels: the
// transposed networks (the lanes MLP) or the int8 layers' held inputs, the lane groups' normals and their full body
// contact. Worked out at load, so that instance creation sizes the context's pool from it.
size_t plBatchScratchFloats( const plContextData* ctx, const plAssetData* a )
{
	const plBatchKernels* kernels = ctx->kernels.batch;
	size_t floats = 0;
	if ( kernels == NULL )
	{
		return 0;
	}
	if ( kernels->geometry_lanes > 1 )
	{
		floats = plNormalsBatchScratchFloats( a->vertex_count, kernels->geometry_lanes );
		size_t contact = kernels->body_contact_batch != NULL ? plBodyContactBatchScratchFloats( a->body_point_count, kernels->geometry_lanes )
															 : 0;
		floats = contact > floats ? contact : floats;
	}
	if ( kernels->mat_mat_lanes != NULL )
	{
		size_t lp = plMlpBatchLanesFloats( a->lp, a->lp_layer_count, PLEAT_BATCH_MAX );
		size_t dec = plMlpBatchLanesFloats( a->dec, a->dec_layer_count, PLEAT_BATCH_MAX );
		floats = lp > floats ? lp : floats;
		floats = dec > floats ? dec : floats;
	}
	if ( ctx->kernels.mat_mat_int8 != NULL )
	{
		size_t lp = plMlpBatchHeldFloats( a->lp, a->lp_layer_count, PLEAT_BATCH_MAX );
		size_t dec = plMlpBatchHeldFloats( a->dec, a->dec_layer_count, PLEAT_BATCH_MAX );
		floats = lp > floats ? lp : floats;
		floats = dec > floats ? dec : floats;
	}
	return floats;
}
