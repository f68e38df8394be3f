// The scene (pleat.h, SCENE BUDGET; docs/scene-budget.md): characters dressed in one garment that comes in several
// tiers, a level of detail per character chosen every frame by the budget policy (scene_budget.c). This file makes
// the scene and its levels (the details a character can show, with what each costs) and answers its API between
// steps; scene_step.c steps it.
//
// Levels: [0] LBS-only, then for each tier its full rate and each reduced rate. Every character has one instance per
// tier (created with it), so a switch allocates nothing. Outputs live on the display mesh (tiers[0]'s); other meshes
// are carried over by tier_transfer.c.
#include "scene.h"

#include <math.h>
#include <string.h>

// Cost model of a tier when the def gives none (µs, a crowd on one core; docs/scene-budget.md, "The scene budget"): the batched
// networks and blend at ~37 GMAC/s, skinning + body contact + normals + guards ~12 ns per vertex, a carry-over to the
// display mesh (map + normals there) ~12 ns per display vertex, ~2 µs per character of fixed work (validation,
// forward kinematics, X_c, commit), and the weights and blend shapes streamed once per frame for the whole group at
// ~150 GB/s of effective overlap. Fitted by bench/fit_scene_costs.py to a pleat_bench_crowd --scene calibration of the
// shipped tiers (2026-11-25, fixed cost held at the per-phase bench's 2 µs). The fit to the later calibrations (staggered updates, batched LBS-only level) gives
// ~45 GMAC/s, but the crowd renderer, which draws between steps, measures its scenes 8–25 % above these estimates
// already (caches cold at every frame), so the tiers keep the more cautious constants. The LBS-only level, whose
// geometry runs the batched kernels in lane groups (plStepLbsLevel), has its own: ~7.6 ns per display
// vertex (the same fit). Measure and pass tier_cost_us for a real budget, or report frame costs
// (plScene_ReportFrameCost).
#define PLEAT_COST_US_PER_MAC 0.027e-3
// A network layer's multiply-adds by precision, against fp32's (the crowd's networks phase per MAC in
// bench/results/cpu-int8.json, 64 instances on one worker of an AVX-512 VNNI Xeon: fp16 0.88 on the t-shirt and 1.05 at
// the reference sizes, int8 0.86 and 0.91; the means). The blend stays fp32 arithmetic whatever its storage.
#define PLEAT_COST_FP16_MAC_SHARE 0.96
#define PLEAT_COST_INT8_MAC_SHARE 0.89
#define PLEAT_COST_US_PER_VERTEX 0.012
#define PLEAT_COST_US_PER_DISPLAY_VERTEX 0.012
#define PLEAT_COST_US_LBS_PER_VERTEX 0.0076
#define PLEAT_COST_US_FIXED 2.0
#define PLEAT_COST_US_PER_STREAMED_BYTE 0.0067e-3
// A GPU detail's CPU side beyond the fixed work: its positions and normals read back and copied (24 bytes a vertex,
// ~2 ns at the ~12 GB/s of a mapped read-back; not measured on a GPU yet: pass tier_gpu_cpu_cost_us).
#define PLEAT_COST_US_GPU_READ_BACK_PER_VERTEX 0.002

plSceneDef plDefaultSceneDef( void )
{
	plSceneDef def = { .internal_cookie = PLEAT_DEF_COOKIE };
	return def;
}

plCharacterDef plDefaultCharacterDef( void )
{
	plCharacterDef def = { .importance = 1.0f, .internal_cookie = PLEAT_DEF_COOKIE };
	return def;
}

plSceneData* plGetSceneData( plScene handle )
{
	plContextData* ctx = plGetContext( handle.context );
	return ctx != NULL ? (plSceneData*)plSlotTable_Get( &ctx->scenes, handle.index1, handle.generation ) : NULL;
}

int plScene_IsValid( plScene handle )
{
	return plGetSceneData( handle ) != NULL;
}

// ---- levels ----

static uint32_t plLevelOf( const plSceneData* s, int32_t tier, float rate_hz, int32_t gpu )
{
	for ( uint32_t l = 0; l < s->level_count; ++l )
	{
		if ( s->levels[l].tier == tier &&
			 ( tier < 0 ? gpu == 0 : s->levels[l].rate_hz == rate_hz && s->levels[l].gpu == ( gpu != 0 ) ) )
		{
			return l;
		}
	}
	return UINT32_MAX;
}

float plSceneGpuWeight( const plSceneData* s )
{
	if ( s->budget_us > 0.0f && s->gpu_budget_us > 0.0f )
	{
		return s->budget_us / s->gpu_budget_us;
	}
	if ( s->budget_us > 0.0f )
	{
		return 1e-3f;
	}
	return s->gpu_budget_us > 0.0f ? 1e3f : 1.0f;
}

// The frontier of the levels `take` keeps (by index), mapped back to the scene's indices.
static uint32_t plSubsetFrontier( const plSceneData* s, const uint8_t* take, float weight, uint32_t* out )
{
	plBudgetLevel subset[PLEAT_SCENE_MAX_LEVELS];
	uint32_t index[PLEAT_SCENE_MAX_LEVELS], count = 0, local[PLEAT_SCENE_MAX_LEVELS];
	for ( uint32_t l = 0; l < s->level_count; ++l )
	{
		if ( take[l] )
		{
			subset[count] = s->levels[l];
			index[count++] = l;
		}
	}
	uint32_t k = plBudgetFrontierWeighted( subset, count, weight, local );
	for ( uint32_t i = 0; i < k; ++i )
	{
		out[i] = index[local[i]];
	}
	return k;
}

void plBuildFrontiers( plSceneData* s )
{
	float weight = plSceneGpuWeight( s );
	uint8_t take[PLEAT_SCENE_MAX_LEVELS];
	for ( uint32_t l = 0; l < s->level_count; ++l )
	{
		take[l] = !s->levels[l].gpu;
	}
	s->frontier_count = plSubsetFrontier( s, take, weight, s->frontier );
	s->gpu_frontier_count = 0;
	if ( s->gpu_mode == PLEAT_GPU_MODE_NONE )
	{
		return;
	}
	// From the CPU frontier's cheapest level (where every free character starts) up the hull of the GPU levels more
	// accurate than it. The first of them may cost less than that start (a GPU detail's CPU share against LBS-only's
	// skinning): the policy takes such a step first, as a free improvement (plSceneBudgetJob_Run).
	const plBudgetLevel* base = &s->levels[s->frontier[0]];
	for ( uint32_t l = 0; l < s->level_count; ++l )
	{
		take[l] = s->levels[l].gpu && s->levels[l].error_mm < base->error_mm;
	}
	s->gpu_frontier[0] = s->frontier[0];
	s->gpu_frontier_count = 1 + plSubsetFrontier( s, take, weight, s->gpu_frontier + 1 );
}

// A layer's multiply-adds in fp32 equivalents (a block-structured layer multiplies its windows only).
static double plLayerCostMacs( const plLayer* l )
{
	double share = l->weight_int8 ? PLEAT_COST_INT8_MAC_SHARE : ( l->weight_fp16 ? PLEAT_COST_FP16_MAC_SHARE : 1.0 );
	return share * (double)plLayerMacs( l );
}

static double plNetworkMacs( const plAssetData* a )
{
	double macs = (double)a->blend_count * a->vertex_count * 3.0;
	for ( uint32_t i = 0; i < a->lp_layer_count; ++i )
	{
		macs += plLayerCostMacs( &a->lp[i] );
	}
	for ( uint32_t i = 0; i < a->dec_layer_count; ++i )
	{
		macs += plLayerCostMacs( &a->dec[i] );
	}
	return macs;
}

static double plStreamedBytes( const plAssetData* a )
{
	double bytes = (double)a->blend_count * a->vertex_count * 3.0 * plShapeBytes( a->blend_shapes.type );
	for ( uint32_t i = 0; i < a->lp_layer_count; ++i )
	{
		bytes += (double)plLayerMacs( &a->lp[i] ) * plWeightBytes( &a->lp[i] ); // the weights read
	}
	for ( uint32_t i = 0; i < a->dec_layer_count; ++i )
	{
		bytes += (double)plLayerMacs( &a->dec[i] ) * plWeightBytes( &a->dec[i] );
	}
	return bytes;
}

// Fills s->levels, their frontier and the tiers' stream costs from the def (or the cost model).
static void plBuildLevels( plSceneData* s, const plSceneDef* def )
{
	uint32_t n0 = s->display_vertex_count;
	float frame_rate = def->frame_rate_hz > 0.0f ? def->frame_rate_hz : 60.0f;
	float lbs_error = def->lbs_error_mm > 0.0f ? def->lbs_error_mm : 1.0f;
	s->levels[0].tier = -1;
	s->levels[0].rate_hz = 0.0f;
	s->levels[0].cost_us =
		def->lbs_cost_us > 0.0f ? def->lbs_cost_us : (float)( PLEAT_COST_US_LBS_PER_VERTEX * n0 + PLEAT_COST_US_FIXED );
	s->levels[0].error_mm = lbs_error;
	s->level_count = 1;
	for ( uint32_t t = 0; t < s->tier_count; ++t )
	{
		const plAssetData* a = s->tiers[t].asset;
		double carry = s->tiers[t].same_mesh ? 0.0 : PLEAT_COST_US_PER_DISPLAY_VERTEX * n0;
		double skin = def->tier_skin_cost_us != NULL
						  ? def->tier_skin_cost_us[t]
						  : PLEAT_COST_US_PER_VERTEX * a->vertex_count + PLEAT_COST_US_FIXED + carry;
		double full = def->tier_cost_us != NULL ? def->tier_cost_us[t]
												: PLEAT_COST_US_PER_MAC * plNetworkMacs( a ) + skin;
		s->tier_stream_cost_us[t] = def->tier_stream_cost_us != NULL
										? def->tier_stream_cost_us[t]
										: (float)( PLEAT_COST_US_PER_STREAMED_BYTE * plStreamedBytes( a ) );
		float error = def->tier_error_mm != NULL ? def->tier_error_mm[t]
												 : lbs_error * (float)( t + 1 ) / (float)( s->tier_count + 1 );
		for ( uint32_t r = 0; r <= def->network_rate_count; ++r )
		{
			plBudgetLevel* l = &s->levels[s->level_count++];
			l->tier = (int32_t)t;
			l->rate_hz = r == 0 ? 0.0f : def->network_rates_hz[r - 1];
			double share = r == 0 ? 1.0 : l->rate_hz / frame_rate; // the frames that run the networks
			l->cost_us = (float)( share * full + ( 1.0 - share ) * skin );
			float extra = 0.0f;
			if ( r > 0 )
			{
				extra = def->network_rate_error_mm != NULL ? def->network_rate_error_mm[r - 1]
														   : 0.02f * error * log2f( frame_rate / l->rate_hz );
			}
			l->error_mm = error + extra;
			l->gpu_cost_us = 0.0f;
			l->gpu = 0;
		}
	}
	// The same details on the GPU: their GPU time from the def (measured: scripts/gpu-bench.sh), the CPU's share of
	// them (validation, forward kinematics, X_c, the upload and read-back, the carry-over) from the def or estimated.
	uint32_t cpu_levels = s->level_count;
	for ( uint32_t i = 1; s->gpu_mode != PLEAT_GPU_MODE_NONE && i < cpu_levels; ++i )
	{
		const plBudgetLevel* on_cpu = &s->levels[i];
		uint32_t t = (uint32_t)on_cpu->tier;
		const plAssetData* a = s->tiers[t].asset;
		double carry = s->tiers[t].same_mesh ? 0.0 : PLEAT_COST_US_PER_DISPLAY_VERTEX * n0;
		double cpu_share = def->tier_gpu_cpu_cost_us != NULL
							   ? def->tier_gpu_cpu_cost_us[t]
							   : PLEAT_COST_US_FIXED + PLEAT_COST_US_GPU_READ_BACK_PER_VERTEX * a->vertex_count + carry;
		double gpu_full = def->tier_gpu_cost_us[t];
		double gpu_skin = def->tier_gpu_skin_cost_us != NULL ? def->tier_gpu_skin_cost_us[t] : gpu_full;
		double share = on_cpu->rate_hz > 0.0f ? on_cpu->rate_hz / frame_rate : 1.0;
		plBudgetLevel* l = &s->levels[s->level_count++];
		*l = *on_cpu;
		l->cost_us = (float)cpu_share;
		l->gpu_cost_us = (float)( share * gpu_full + ( 1.0 - share ) * gpu_skin );
		l->gpu = 1;
	}
	plBuildFrontiers( s );
}

// ---- create / destroy ----

static void plDestroyCharacter( plSceneData* s, plSceneCharacter* c )
{
	(void)s;
	// The GPU instances first (the CPU ones share nothing with them; among the GPU ones the shared block goes with
	// its last user, whichever character that is).
	for ( int32_t slot = 2 * PLEAT_MAX_TIERS - 1; slot >= 0; --slot )
	{
		if ( c->instances[slot].index1 != 0 )
		{
			plDestroyInstance( c->instances[slot] );
		}
	}
	float *positions = c->positions, *normals = c->normals;
	float *back_positions = c->back_positions, *back_normals = c->back_normals;
	memset( c, 0, sizeof( *c ) );
	c->positions = positions, c->normals = normals;
	c->back_positions = back_positions, c->back_normals = back_normals;
}

// The scene table's destroy callback, also what plDestroyScene frees with.
static void plSceneData_Destroy( plContextData* ctx, void* object )
{
	plSceneData* s = (plSceneData*)object;
	for ( uint32_t t = 0; s->uses_tiers && t < s->tier_count; ++t )
	{
		s->tiers[t].asset->instance_count -= 1;
	}
	for ( uint32_t i = 0; s->characters != NULL && i < s->capacity; ++i )
	{
		if ( s->characters[i].live )
		{
			plDestroyCharacter( s, &s->characters[i] );
		}
	}
	plFree( &ctx->allocator, s->block, s->block_size );
	plFree( &ctx->allocator, s, sizeof( plSceneData ) );
}

static plResult plBadSceneDef( plContextData* ctx, const char* what )
{
	plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_SCENE_BAD_DEF, "%s", what );
	return PLEAT_RESULT_INVALID_DEF;
}

// The def's fields, each rejection naming its field.
static plResult plCheckSceneDef( plContextData* ctx, const plSceneDef* def )
{
	if ( def->internal_cookie != PLEAT_DEF_COOKIE )
	{
		return plBadSceneDef( ctx, "internal_cookie: the def was not made by plDefaultSceneDef()" );
	}
	if ( def->tiers == NULL || def->tier_count == 0 || def->tier_count > PLEAT_MAX_TIERS )
	{
		return plBadSceneDef( ctx, "tiers / tier_count: 1..PLEAT_MAX_TIERS assets required" );
	}
	if ( def->network_rate_count > PLEAT_MAX_NETWORK_RATES || ( def->network_rate_count > 0 && def->network_rates_hz == NULL ) )
	{
		return plBadSceneDef( ctx, "network_rates_hz / network_rate_count" );
	}
	float frame_rate = def->frame_rate_hz > 0.0f ? def->frame_rate_hz : 60.0f;
	if ( !isfinite( def->frame_rate_hz ) || def->frame_rate_hz < 0.0f )
	{
		return plBadSceneDef( ctx, "frame_rate_hz: finite, >= 0" );
	}
	for ( uint32_t r = 0; r < def->network_rate_count; ++r )
	{
		if ( !( def->network_rates_hz[r] > 0.0f && def->network_rates_hz[r] < frame_rate ) ||
			 ( def->network_rate_error_mm != NULL && !( def->network_rate_error_mm[r] >= 0.0f ) ) )
		{
			return plBadSceneDef( ctx, "network_rates_hz[r]: in (0, frame_rate_hz); network_rate_error_mm[r] >= 0" );
		}
	}
	for ( uint32_t t = 0; t < def->tier_count; ++t )
	{
		if ( ( def->tier_cost_us != NULL && !( def->tier_cost_us[t] > 0.0f && isfinite( def->tier_cost_us[t] ) ) ) ||
			 ( def->tier_skin_cost_us != NULL && !( def->tier_skin_cost_us[t] > 0.0f ) ) ||
			 ( def->tier_stream_cost_us != NULL && !( def->tier_stream_cost_us[t] >= 0.0f ) ) ||
			 ( def->tier_error_mm != NULL && !( def->tier_error_mm[t] >= 0.0f && isfinite( def->tier_error_mm[t] ) ) ) )
		{
			return plBadSceneDef( ctx, "tier_cost_us / tier_skin_cost_us / tier_stream_cost_us / tier_error_mm: "
									   "positive and finite" );
		}
	}
	if ( def->gpu_mode != PLEAT_GPU_MODE_NONE && def->gpu_mode != PLEAT_GPU_MODE_HOST_CONTEXT &&
		 def->gpu_mode != PLEAT_GPU_MODE_HEADLESS )
	{
		return plBadSceneDef( ctx, "gpu_mode: a plGpuMode" );
	}
	if ( def->gpu_mode != PLEAT_GPU_MODE_NONE && def->tier_gpu_cost_us == NULL )
	{
		return plBadSceneDef( ctx, "tier_gpu_cost_us: required with a gpu_mode (measure it: scripts/gpu-bench.sh)" );
	}
	for ( uint32_t t = 0; def->gpu_mode != PLEAT_GPU_MODE_NONE && t < def->tier_count; ++t )
	{
		if ( !( def->tier_gpu_cost_us[t] > 0.0f && isfinite( def->tier_gpu_cost_us[t] ) ) ||
			 ( def->tier_gpu_skin_cost_us != NULL &&
			   !( def->tier_gpu_skin_cost_us[t] > 0.0f && isfinite( def->tier_gpu_skin_cost_us[t] ) ) ) ||
			 ( def->tier_gpu_cpu_cost_us != NULL &&
			   !( def->tier_gpu_cpu_cost_us[t] > 0.0f && isfinite( def->tier_gpu_cpu_cost_us[t] ) ) ) )
		{
			return plBadSceneDef( ctx, "tier_gpu_cost_us / tier_gpu_skin_cost_us / tier_gpu_cpu_cost_us: positive "
									   "and finite" );
		}
	}
	if ( !( def->gpu_budget_us >= 0.0f && isfinite( def->gpu_budget_us ) ) )
	{
		return plBadSceneDef( ctx, "gpu_budget_us: finite, >= 0" );
	}
	if ( !( def->budget_us >= 0.0f && isfinite( def->budget_us ) ) || !isfinite( def->hysteresis ) ||
		 !( def->lbs_cost_us >= 0.0f && isfinite( def->lbs_cost_us ) ) ||
		 !( def->lbs_error_mm >= 0.0f && isfinite( def->lbs_error_mm ) ) )
	{
		return plBadSceneDef( ctx, "budget_us, lbs_cost_us, lbs_error_mm: finite, >= 0; hysteresis finite" );
	}
	return PLEAT_RESULT_OK;
}

// The tiers: live assets of this context with one skeleton.
static plResult plGatherTiers( plContextData* ctx, plSceneData* s, const plSceneDef* def )
{
	for ( uint32_t t = 0; t < def->tier_count; ++t )
	{
		plAssetData* a = plGetAssetData( def->tiers[t] );
		if ( a == NULL || plGetContext( def->tiers[t].context ) != ctx )
		{
			plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_SCENE_BAD_DEF, "tiers[%u]: null, destroyed or another context's",
				   t );
			return PLEAT_RESULT_INVALID_HANDLE;
		}
		const plAssetData* a0 = s->tiers[0].asset != NULL ? s->tiers[0].asset : a;
		if ( a->joint_count != a0->joint_count ||
			 memcmp( a->joint_names, a0->joint_names, (size_t)a->joint_count * PLEAT_JOINT_NAME_SIZE ) != 0 ||
			 memcmp( a->parents, a0->parents, (size_t)a->joint_count * sizeof( int32_t ) ) != 0 )
		{
			plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_SCENE_BAD_DEF, "tiers[%u]: another skeleton than tiers[0]'s", t );
			return PLEAT_RESULT_INVALID_DEF;
		}
		s->tiers[t].asset = a;
		s->tiers[t].handle = def->tiers[t];
		s->tiers[t].same_mesh =
			a->vertex_count == a0->vertex_count && a->face_count == a0->face_count &&
			memcmp( a->faces, a0->faces, (size_t)a->face_count * 12 ) == 0 &&
			memcmp( a->template_positions, a0->template_positions, (size_t)a->vertex_count * 12 ) == 0;
	}
	s->tier_count = def->tier_count;
	s->display_vertex_count = s->tiers[0].asset->vertex_count;
	return PLEAT_RESULT_OK;
}

// One block for everything the scene needs while it lives: characters, display buffers, transfer maps, scratch.
static plResult plAllocateScene( plContextData* ctx, plSceneData* s )
{
	uint32_t cap = s->capacity, n0 = s->display_vertex_count;
	size_t display = (size_t)n0 * 3 * sizeof( float );
	s->budget_scratch_bytes =
		( plSceneBudgetScratchBytes( cap, PLEAT_SCENE_MAX_LEVELS, PLEAT_SCENE_MAX_LEVELS ) + 3u ) & ~(size_t)3u;
	size_t live_ids = (size_t)cap * sizeof( uint32_t );
	// Each task worker finishes its characters in its own fade scratch (plFinishCharacters).
	uint32_t workers = s->worker_count;
	size_t sizes[16] = {
		(size_t)cap * sizeof( plSceneCharacter ), (size_t)cap * 4 * display, (size_t)cap * sizeof( float ),
		(size_t)cap * sizeof( uint32_t ),         (size_t)cap * sizeof( int32_t ), (size_t)cap * sizeof( int32_t ),
		(size_t)cap * 2 * sizeof( float ),        (size_t)cap * sizeof( uint32_t ), s->budget_scratch_bytes + live_ids,
		(size_t)cap * 2 * sizeof( plInstance ),   (size_t)cap * 2 * sizeof( plFrameInput ),
		(size_t)cap * 2 * sizeof( plResult ),     workers * 2 * display,
		0,                                        (size_t)cap * 2 * sizeof( plResult ), (size_t)cap * 2 * sizeof( uint32_t ) };
	size_t transfer = 0;
	for ( uint32_t t = 0; t < s->tier_count; ++t )
	{
		transfer += s->tiers[t].same_mesh ? 0 : 3 * plAlign64( (size_t)n0 * 12 );
	}
	sizes[13] = transfer;
	size_t total = 0;
	for ( int i = 0; i < 16; ++i )
	{
		total += plAlign64( sizes[i] );
	}
	s->block = plAllocZeroed( &ctx->allocator, total, 64 );
	if ( s->block == NULL )
	{
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	s->block_size = total;
	uint8_t* p = (uint8_t*)s->block;
	void* parts[16];
	for ( int i = 0; i < 16; ++i )
	{
		parts[i] = p;
		p += plAlign64( sizes[i] );
	}
	s->characters = (plSceneCharacter*)parts[0];
	for ( uint32_t i = 0; i < cap; ++i )
	{
		s->characters[i].positions = (float*)parts[1] + (size_t)i * 4 * n0 * 3;
		s->characters[i].normals = s->characters[i].positions + (size_t)n0 * 3;
		s->characters[i].back_positions = s->characters[i].normals + (size_t)n0 * 3;
		s->characters[i].back_normals = s->characters[i].back_positions + (size_t)n0 * 3;
	}
	s->importance = (float*)parts[2];
	s->current = (uint32_t*)parts[3];
	s->pinned = (int32_t*)parts[4];
	s->held = (int32_t*)parts[5];
	s->extra_cost_us = (float*)parts[6];
	s->extra_gpu_cost_us = s->extra_cost_us + cap;
	s->planned = (uint32_t*)parts[7];
	s->budget_scratch = parts[8];
	s->live_ids = (uint32_t*)( (uint8_t*)parts[8] + s->budget_scratch_bytes );
	s->step_instances = (plInstance*)parts[9];
	s->step_inputs = (plFrameInput*)parts[10];
	s->step_results = (plResult*)parts[11];
	s->fade_positions = (float*)parts[12];
	s->verdicts = (plResult*)parts[14];
	s->lbs_results = s->verdicts + cap;
	s->result_index = (uint32_t*)parts[15];
	s->lbs_members = s->result_index + cap;
	uint8_t* q = (uint8_t*)parts[13];
	for ( uint32_t t = 0; t < s->tier_count; ++t )
	{
		if ( s->tiers[t].same_mesh )
		{
			continue;
		}
		s->tiers[t].triangles = (uint32_t*)q;
		s->tiers[t].weights = (float*)( q + plAlign64( (size_t)n0 * 12 ) );
		s->tiers[t].offsets = (float*)( q + 2 * plAlign64( (size_t)n0 * 12 ) );
		q += 3 * plAlign64( (size_t)n0 * 12 );
	}
	return PLEAT_RESULT_OK;
}

plResult plCreateScene( plContext context, const plSceneDef* def, plScene* out_scene )
{
	plContextData* ctx;
	plResult r = plBeginCreate( context, def, out_scene, sizeof( *out_scene ), &ctx );
	if ( r == PLEAT_RESULT_OK )
	{
		r = plCheckSceneDef( ctx, def );
	}
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	plSceneData* s = (plSceneData*)plAllocZeroed( &ctx->allocator, sizeof( plSceneData ), 64 );
	if ( s == NULL )
	{
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	s->ctx = ctx;
	s->capacity = def->character_capacity != 0 ? def->character_capacity : 64;
	s->budget_us = def->budget_us;
	s->hysteresis = def->hysteresis == 0.0f ? 0.25f : ( def->hysteresis < 0.0f ? 0.0f : def->hysteresis );
	s->min_frames_between_switches = def->min_frames_between_switches != 0 ? def->min_frames_between_switches : 30;
	s->crossfade_frames = def->crossfade_frames != 0 ? def->crossfade_frames : 8;
	s->cost_scale = 1.0f;
	s->gpu_mode = def->gpu_mode;
	s->gpu_budget_us = def->gpu_budget_us;
	s->worker_count = ctx->runner.worker_count;
	r = plGatherTiers( ctx, s, def );
	if ( r == PLEAT_RESULT_OK )
	{
		r = plAllocateScene( ctx, s );
	}
	for ( uint32_t t = 0; r == PLEAT_RESULT_OK && t < s->tier_count; ++t )
	{
		const plAssetData* a = s->tiers[t].asset;
		plTierTransferJob transfer = { s->tiers[0].asset->template_positions, s->display_vertex_count,
									   a->template_positions, a->vertex_count, a->faces, a->face_count,
									   s->tiers[t].triangles, s->tiers[t].weights, s->tiers[t].offsets };
		r = s->tiers[t].same_mesh || plTierTransferJob_Build( &transfer ) == PLEAT_RESULT_OK ? PLEAT_RESULT_OK
																							  : PLEAT_RESULT_INTERNAL_ERROR;
	}
	if ( r == PLEAT_RESULT_OK )
	{
		plBuildLevels( s, def );
		r = plSlotTable_Insert( ctx, &ctx->scenes, s, plSceneData_Destroy, &out_scene->index1,
								&out_scene->generation );
	}
	if ( r != PLEAT_RESULT_OK )
	{
		plSceneData_Destroy( ctx, s );
		return r;
	}
	for ( uint32_t t = 0; t < s->tier_count; ++t )
	{
		s->tiers[t].asset->instance_count += 1; // the scene uses its tiers: plDestroyAsset waits for it
	}
	s->uses_tiers = 1;
	out_scene->context = ctx->handle;
	plLog( ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_SCENE_CREATED,
		   "%u tiers, %u levels (%u on the frontier, %u on the GPU's), %u characters", s->tier_count, s->level_count,
		   s->frontier_count, s->gpu_frontier_count, s->capacity );
	return PLEAT_RESULT_OK;
}

plResult plDestroyScene( plScene handle )
{
	plContextData* ctx = plGetContext( handle.context );
	return ctx != NULL ? plSlotTable_Destroy( ctx, &ctx->scenes, handle.index1, handle.generation )
					   : PLEAT_RESULT_INVALID_HANDLE;
}

// ---- characters ----

static plSceneCharacter* plGetCharacter( plSceneData* s, uint32_t character )
{
	return s != NULL && character < s->capacity && s->characters[character].live ? &s->characters[character] : NULL;
}

plResult plScene_AddCharacter( plScene handle, const plCharacterDef* def, uint32_t* out_character )
{
	plSceneData* s = plGetSceneData( handle );
	plResult r = plCheckHandleThenArguments( s, def != NULL && out_character != NULL );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	if ( def->internal_cookie != PLEAT_DEF_COOKIE )
	{
		return plBadSceneDef( s->ctx, "character internal_cookie: the def was not made by plDefaultCharacterDef()" );
	}
	if ( !( def->importance >= 0.0f && isfinite( def->importance ) ) )
	{
		return plBadSceneDef( s->ctx, "character importance: finite, >= 0" );
	}
	uint32_t id = 0;
	while ( id < s->capacity && s->characters[id].live )
	{
		id++;
	}
	if ( id == s->capacity )
	{
		return PLEAT_RESULT_CAPACITY_EXCEEDED;
	}
	plSceneCharacter* c = &s->characters[id];
	int clamped = 0;
	for ( uint32_t t = 0; t < s->tier_count && r >= 0; ++t )
	{
		plInstanceDef idef = plDefaultInstanceDef();
		idef.asset = s->tiers[t].handle;
		idef.joint_map = def->joint_map;
		idef.joint_map_count = def->joint_map_count;
		idef.engine_joint_count = def->engine_joint_count;
		idef.beta = def->beta;
		idef.beta_count = def->beta_count < s->tiers[t].asset->beta_count ? def->beta_count : s->tiers[t].asset->beta_count;
		idef.material = def->material;
		r = plCreateInstance( handle.context, &idef, &c->instances[t] );
		clamped |= r == PLEAT_RESULT_CLAMPED;
		if ( r >= 0 && s->gpu_mode != PLEAT_GPU_MODE_NONE )
		{
			// The tier on the GPU, sharing the tier's GPU data with any other character's GPU instance of it.
			idef.gpu_mode = s->gpu_mode;
			idef.mlp_backend = PLEAT_MLP_BACKEND_GPU;
			for ( uint32_t other = 0; other < s->capacity; ++other )
			{
				if ( s->characters[other].live && other != id )
				{
					idef.gpu_share = s->characters[other].instances[PLEAT_MAX_TIERS + t];
					break;
				}
			}
			r = plCreateInstance( handle.context, &idef, &c->instances[PLEAT_MAX_TIERS + t] );
			if ( r >= 0 )
			{
				// The scene reads its outputs on the CPU (cross-fades, the display mesh, the caller's spans).
				plGetInstanceData( c->instances[PLEAT_MAX_TIERS + t] )->read_back_always = 1;
			}
		}
	}
	if ( r < 0 )
	{
		plDestroyCharacter( s, c );
		return r;
	}
	c->live = 1;
	c->importance = def->importance;
	c->user_data = def->user_data;
	c->override_level = -1;
	c->frames_since_switch = UINT32_MAX / 2;
	c->fade_alpha = 1.0f;
	const float *positions, *normals;
	plInstance_GetPositions( c->instances[0], &positions, NULL );
	plInstance_GetNormals( c->instances[0], &normals, NULL );
	memcpy( c->positions, positions, (size_t)s->display_vertex_count * 12 );
	memcpy( c->normals, normals, (size_t)s->display_vertex_count * 12 );
	*out_character = id;
	return clamped ? PLEAT_RESULT_CLAMPED : PLEAT_RESULT_OK;
}

plResult plScene_RemoveCharacter( plScene handle, uint32_t character )
{
	plSceneData* s = plGetSceneData( handle );
	plSceneCharacter* c = plGetCharacter( s, character );
	if ( c == NULL )
	{
		return s == NULL ? PLEAT_RESULT_INVALID_HANDLE : PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plDestroyCharacter( s, c );
	return PLEAT_RESULT_OK;
}

plResult plScene_SetImportance( plScene handle, uint32_t character, float importance )
{
	plSceneData* s = plGetSceneData( handle );
	plSceneCharacter* c = plGetCharacter( s, character );
	if ( c == NULL || !( importance >= 0.0f && isfinite( importance ) ) )
	{
		return s == NULL ? PLEAT_RESULT_INVALID_HANDLE : PLEAT_RESULT_INVALID_ARGUMENT;
	}
	c->importance = importance;
	return PLEAT_RESULT_OK;
}

plResult plScene_SetBudget( plScene handle, float budget_us )
{
	plSceneData* s = plGetSceneData( handle );
	plResult r = plCheckHandleThenArguments( s, budget_us >= 0.0f && isfinite( budget_us ) );
	if ( r == PLEAT_RESULT_OK )
	{
		s->budget_us = budget_us;
		plBuildFrontiers( s ); // a GPU scene weighs GPU µs by the budgets' ratio
	}
	return r;
}

plResult plScene_SetGpuBudget( plScene handle, float gpu_budget_us )
{
	plSceneData* s = plGetSceneData( handle );
	plResult r = plCheckHandleThenArguments( s, s != NULL && s->gpu_mode != PLEAT_GPU_MODE_NONE &&
													gpu_budget_us >= 0.0f && isfinite( gpu_budget_us ) );
	if ( r == PLEAT_RESULT_OK )
	{
		s->gpu_budget_us = gpu_budget_us;
		plBuildFrontiers( s );
	}
	return r;
}

plResult plScene_SetOverride( plScene handle, uint32_t character, const plDetail* detail )
{
	plSceneData* s = plGetSceneData( handle );
	plSceneCharacter* c = plGetCharacter( s, character );
	if ( c == NULL )
	{
		return s == NULL ? PLEAT_RESULT_INVALID_HANDLE : PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( detail == NULL )
	{
		c->override_level = -1;
		return PLEAT_RESULT_OK;
	}
	uint32_t level = detail->tier < (int32_t)s->tier_count
						 ? plLevelOf( s, detail->tier, detail->network_rate_hz, detail->gpu )
						 : UINT32_MAX;
	if ( level == UINT32_MAX )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	c->override_level = (int32_t)level;
	return PLEAT_RESULT_OK;
}

static plDetail plDetailOf( const plSceneData* s, uint32_t level )
{
	plDetail d = { s->levels[level].tier, s->levels[level].rate_hz, s->levels[level].gpu };
	return d;
}

plResult plScene_GetDetail( plScene handle, uint32_t character, plDetail* out_detail, plDetail* out_from,
						   float* out_fade )
{
	plSceneData* s = plGetSceneData( handle );
	plSceneCharacter* c = plGetCharacter( s, character );
	if ( c == NULL || out_detail == NULL )
	{
		return s == NULL ? PLEAT_RESULT_INVALID_HANDLE : PLEAT_RESULT_INVALID_ARGUMENT;
	}
	int fading = c->fade_alpha < 1.0f;
	*out_detail = plDetailOf( s, c->level );
	if ( out_from != NULL )
	{
		*out_from = plDetailOf( s, fading ? c->fade_from : c->level );
	}
	if ( out_fade != NULL )
	{
		*out_fade = c->fade_alpha;
	}
	return PLEAT_RESULT_OK;
}

plResult plScene_GetPlan( plScene handle, plScenePlan* out_plan )
{
	const plSceneData* s = plGetSceneData( handle );
	plResult r = plCheckHandleThenArguments( s, out_plan != NULL );
	if ( r == PLEAT_RESULT_OK )
	{
		*out_plan = s->plan;
	}
	return r;
}

plResult plScene_ReportFrameCost( plScene handle, float measured_us )
{
	plSceneData* s = plGetSceneData( handle );
	plResult r = plCheckHandleThenArguments( s, measured_us > 0.0f && isfinite( measured_us ) );
	if ( r == PLEAT_RESULT_OK && s->model_cost_us > 0.0f )
	{
		// The ratio of two running means (≈ 20 frames), not a running mean of per-frame ratios: a frame where many
		// characters update their networks at once and the cheap frames around it weigh by what they cost, so a
		// rate's rhythm does not make the correction, and with it the plan, swing from frame to frame.
		if ( s->modelled_avg_us <= 0.0 ) // the first report: start from the model (scale 1), as before any report
		{
			s->measured_avg_us = s->modelled_avg_us = s->model_cost_us;
		}
		s->measured_avg_us = 0.95 * s->measured_avg_us + 0.05 * measured_us;
		s->modelled_avg_us = 0.95 * s->modelled_avg_us + 0.05 * s->model_cost_us;
		float scale = (float)( s->measured_avg_us / s->modelled_avg_us );
		s->cost_scale = scale < 0.25f ? 0.25f : ( scale > 4.0f ? 4.0f : scale );
	}
	return r;
}

static plResult plGetOutput( plScene handle, uint32_t character, int normals, const float** out, uint32_t* out_count )
{
	plSceneData* s = plGetSceneData( handle );
	plSceneCharacter* c = plGetCharacter( s, character );
	if ( c == NULL || out == NULL )
	{
		return s == NULL ? PLEAT_RESULT_INVALID_HANDLE : PLEAT_RESULT_INVALID_ARGUMENT;
	}
	*out = normals ? c->normals : c->positions;
	if ( out_count != NULL )
	{
		*out_count = s->display_vertex_count;
	}
	return PLEAT_RESULT_OK;
}

plResult plScene_GetPositions( plScene handle, uint32_t character, const float** out_positions, uint32_t* out_count )
{
	return plGetOutput( handle, character, 0, out_positions, out_count );
}

plResult plScene_GetNormals( plScene handle, uint32_t character, const float** out_normals, uint32_t* out_count )
{
	return plGetOutput( handle, character, 1, out_normals, out_count );
}

plResult plScene_GetSkinMatrices( plScene handle, uint32_t character, float* out, uint32_t joint_count )
{
	plSceneData* s = plGetSceneData( handle );
	plSceneCharacter* c = plGetCharacter( s, character );
	if ( c == NULL || out == NULL )
	{
		return s == NULL ? PLEAT_RESULT_INVALID_HANDLE : PLEAT_RESULT_INVALID_ARGUMENT;
	}
	uint32_t j = s->tiers[0].asset->joint_count;
	if ( joint_count < j )
	{
		return PLEAT_RESULT_BUFFER_TOO_SMALL;
	}
	memcpy( out, c->skin_matrices, (size_t)j * 12 * sizeof( float ) );
	return PLEAT_RESULT_OK;
}

plResult plScene_GetCharacterUserData( plScene handle, uint32_t character, void** out_user_data )
{
	plSceneData* s = plGetSceneData( handle );
	plSceneCharacter* c = plGetCharacter( s, character );
	if ( c == NULL || out_user_data == NULL )
	{
		return s == NULL ? PLEAT_RESULT_INVALID_HANDLE : PLEAT_RESULT_INVALID_ARGUMENT;
	}
	*out_user_data = c->user_data;
	return PLEAT_RESULT_OK;
}
