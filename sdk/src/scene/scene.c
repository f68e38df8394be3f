// The scene (pleat.h, SCENE BUDGET; docs/scene-budget.md): characters dressed in one garment that comes in several
// tiers, a level of detail per character chosen every frame by the budget policy (scene_budget.c), switches that
// cross-fade, one plStepInstances call per frame for every network detail shown, the LBS-only characters' geometry
// in lane groups through the same batched kernels (plStepLbsLevel), and the characters finished over the task hooks.
//
// Levels: [0] LBS-only, then for each tier its full rate and each reduced rate. Every character has one instance per
// tier (created with it), so a switch allocates nothing: the new tier's instance is reset (its latent restarts from
// zero, its history from the new pose) and stepped from then on. While a switch fades, the old detail is stepped as
// well and the outputs blend from old to new over crossfade_frames frames, so the largest per-vertex jump of a switch
// is the gap between the two details divided over the fade, on top of the frame's own motion
// (test_tier_switch_does_not_pop). LBS-only skins tiers[0]'s shaped template with the frame's skinning matrices,
// without touching the instance's history. Outputs live on the display mesh (tiers[0]'s); other meshes are carried
// over by tier_transfer.c.
#include "scene.h"
#include "step/step.h"

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
#define PLEAT_COST_US_PER_VERTEX 0.012
#define PLEAT_COST_US_PER_DISPLAY_VERTEX 0.012
#define PLEAT_COST_US_LBS_PER_VERTEX 0.0076
#define PLEAT_COST_US_FIXED 2.0
#define PLEAT_COST_US_PER_STREAMED_BYTE 0.0067e-3

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

static plSceneData* plGetSceneData( plScene handle )
{
	plContextData* ctx = plGetContext( handle.context );
	return ctx != NULL ? (plSceneData*)plSlotTable_Get( &ctx->scenes, handle.index1, handle.generation ) : NULL;
}

int plScene_IsValid( plScene handle )
{
	return plGetSceneData( handle ) != NULL;
}

// ---- levels ----

static int32_t plLevelTier( const plSceneData* s, uint32_t level )
{
	return s->levels[level].tier;
}

static uint32_t plLevelOf( const plSceneData* s, int32_t tier, float rate_hz )
{
	for ( uint32_t l = 0; l < s->level_count; ++l )
	{
		if ( s->levels[l].tier == tier && ( tier < 0 || s->levels[l].rate_hz == rate_hz ) )
		{
			return l;
		}
	}
	return UINT32_MAX;
}

static double plNetworkMacs( const plAssetData* a )
{
	double macs = (double)a->blend_count * a->vertex_count * 3.0;
	for ( uint32_t i = 0; i < a->lp_layer_count; ++i )
	{
		macs += (double)plLayerMacs( &a->lp[i] ); // a block-structured layer multiplies its windows only
	}
	for ( uint32_t i = 0; i < a->dec_layer_count; ++i )
	{
		macs += (double)plLayerMacs( &a->dec[i] );
	}
	return macs;
}

static double plStreamedBytes( const plAssetData* a )
{
	double bytes = (double)a->blend_count * a->vertex_count * 3.0 * ( a->blend_shapes_fp16 ? 2.0 : 4.0 );
	for ( uint32_t i = 0; i < a->lp_layer_count; ++i )
	{
		bytes += (double)plLayerMacs( &a->lp[i] ) * ( a->lp[i].weight_fp16 ? 2.0 : 4.0 ); // the weights read
	}
	for ( uint32_t i = 0; i < a->dec_layer_count; ++i )
	{
		bytes += (double)plLayerMacs( &a->dec[i] ) * ( a->dec[i].weight_fp16 ? 2.0 : 4.0 );
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
		}
	}
	s->frontier_count = plBudgetFrontier( s->levels, s->level_count, s->frontier );
}

// ---- create / destroy ----

static void plDestroyCharacter( plSceneData* s, plSceneCharacter* c )
{
	for ( uint32_t t = 0; t < s->tier_count; ++t )
	{
		if ( c->instances[t].index1 != 0 )
		{
			plDestroyInstance( c->instances[t] );
		}
	}
	float *positions = c->positions, *normals = c->normals;
	float *back_positions = c->back_positions, *back_normals = c->back_normals;
	memset( c, 0, sizeof( *c ) );
	c->positions = positions, c->normals = normals;
	c->back_positions = back_positions, c->back_normals = back_normals;
}

// The share of the budget a plan may fill: 5 % headroom for the frame-to-frame spread of the costs (a reduced network
// rate makes one frame in k heavier) and for the lag of the cost correction (plScene_ReportFrameCost).
#define PLEAT_SCENE_BUDGET_SHARE 0.9f

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
	s->budget_scratch_bytes = (size_t)cap * PLEAT_SCENE_MAX_LEVELS * 12 + (size_t)cap * 4;
	size_t live_ids = (size_t)cap * sizeof( uint32_t );
	// Each task worker finishes its characters in its own fade scratch (plFinishCharacters).
	uint32_t workers = s->worker_count;
	size_t sizes[16] = {
		(size_t)cap * sizeof( plSceneCharacter ), (size_t)cap * 4 * display, (size_t)cap * sizeof( float ),
		(size_t)cap * sizeof( uint32_t ),         (size_t)cap * sizeof( int32_t ), (size_t)cap * sizeof( int32_t ),
		(size_t)cap * sizeof( float ),            (size_t)cap * sizeof( uint32_t ), s->budget_scratch_bytes + live_ids,
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
	plLog( ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_SCENE_CREATED, "%u tiers, %u levels (%u on the frontier), %u characters",
		   s->tier_count, s->level_count, s->frontier_count, s->capacity );
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
	uint32_t level = detail->tier < (int32_t)s->tier_count ? plLevelOf( s, detail->tier, detail->network_rate_hz )
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
	plDetail d = { s->levels[level].tier, s->levels[level].rate_hz };
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

// ---- the step ----

// The policy's plan for every live character (compacted: the job sees only live ones).
static plResult plPlan( plSceneData* s, uint32_t* live, uint32_t live_count )
{
	for ( uint32_t m = 0; m < live_count; ++m )
	{
		const plSceneCharacter* c = &s->characters[live[m]];
		int fading = c->fade_alpha < 1.0f;
		s->importance[m] = c->importance;
		s->current[m] = c->level;
		// A fade runs to its end before the next switch; an override is the engine's.
		s->pinned[m] = c->override_level >= 0 ? c->override_level : ( fading ? (int32_t)c->level : -1 );
		s->held[m] = c->stepped && c->frames_since_switch < s->min_frames_between_switches ? (int32_t)c->level : -1;
		s->extra_cost_us[m] = fading ? s->levels[c->fade_from].cost_us : 0.0f;
	}
	float cost = 0.0f;
	plSceneBudgetJob job = { s->levels,
							 s->level_count,
							 s->frontier,
							 s->frontier_count,
							 s->tier_stream_cost_us,
							 s->tier_count,
							 live_count,
							 s->importance,
							 s->current,
							 s->pinned,
							 s->held,
							 s->extra_cost_us,
							 s->budget_us > 0.0f ? PLEAT_SCENE_BUDGET_SHARE * s->budget_us / s->cost_scale : INFINITY,
							 s->hysteresis,
							 s->budget_scratch,
							 s->budget_scratch_bytes,
							 s->planned,
							 &cost };
	plResult r = plSceneBudgetJob_Run( &job );
	s->model_cost_us = cost;
	s->plan.cost_us = cost * s->cost_scale;
	s->plan.cost_scale = s->cost_scale;
	s->plan.budget_us = s->budget_us;
	return r == PLEAT_RESULT_OK ? PLEAT_RESULT_OK : PLEAT_RESULT_INTERNAL_ERROR;
}

// A character takes its planned level: a rate change in place; any other change restarts the new detail and fades.
// At a reduced network rate, the character's first update after a switch comes early by its own share of the
// interval (the golden-ratio sequence over character slots): characters that switch together — all of them on the
// first frame — then run their networks on different frames instead of all on one, so the frames cost alike and
// the engine sees no spike every 1 / rate. The networks see the true time since their last update.
static void plStaggerNetworkUpdates( const plSceneData* s, const plSceneCharacter* c, int32_t tier, float rate_hz )
{
	if ( rate_hz <= 0.0f )
	{
		return;
	}
	double share = fmod( (double)( c - s->characters ) * 0.6180339887498949, 1.0 );
	plInstanceData* inst = plGetInstanceData( c->instances[tier] );
	inst->network_lead_s = share * inst->network_interval_s;
}

static void plSwitch( plSceneData* s, plSceneCharacter* c, uint32_t target )
{
	int32_t from_tier = plLevelTier( s, c->level ), to_tier = plLevelTier( s, target );
	float rate = s->levels[target].rate_hz;
	s->plan.switches += 1;
	c->frames_since_switch = 0;
	if ( to_tier >= 0 && from_tier == to_tier && c->stepped )
	{
		plInstance_SetNetworkRate( c->instances[to_tier], rate );
		plStaggerNetworkUpdates( s, c, to_tier, rate );
		c->level = target;
		return;
	}
	if ( to_tier >= 0 )
	{
		plInstance_Reset( c->instances[to_tier] );
		plInstance_SetNetworkRate( c->instances[to_tier], rate );
		plStaggerNetworkUpdates( s, c, to_tier, rate );
	}
	c->fade_from = c->level;
	c->fade_alpha = c->stepped ? 0.0f : 1.0f;
	c->level = target;
}

// result_index of a live character whose output spans were rejected (it does not step), and of one that shows no
// network (LBS-only).
#define PLEAT_SCENE_SKIPPED UINT32_MAX
#define PLEAT_SCENE_NO_NETWORK ( UINT32_MAX - 1u )

// The LBS-only level: tiers[0]'s instance of each character in a step group with the networks off (step.c): the pose
// checked, forward kinematics into its scratch frame (the history is not touched), its shaped template skinned with
// those matrices, the fast contact with the instance's clearance (an LBS-only character is a far one: the full contact
// would cost more than its skinning; a switch cross-fades, so it does not pop), normals — into the character's
// positions / normals [N0][3]. A group of more than one runs the batched geometry kernels in lane groups.
static plStepEntry* plAddLbs( plStepGroup* g, plSceneCharacter* c, const plFrameInput* input, float* positions,
							  float* normals )
{
	plStepEntry* e = plStepGroup_Add( g, plGetInstanceData( c->instances[0] ), input, NULL );
	e->positions = positions;
	e->normals = normals;
	return e;
}

// LBS-only for one character (a fade from LBS-only), on the calling worker.
static plResult plStepLbs( const plSceneData* s, plSceneCharacter* c, const plFrameInput* input, float* positions,
						   float* normals )
{
	plStepEntry entry;
	plStepGroup g;
	plStepGroup_Init( &g, s->ctx, s->tiers[0].asset, &entry, 0, NULL, "plScene_Step" );
	plAddLbs( &g, c, input, positions, normals );
	plRunStepGroup( &g );
	return entry.result;
}

// The LBS-only level of this frame, before the characters are finished: every live character shown LBS-only gets
// its outputs in its back buffers and its result in lbs_results, in groups of up to PLEAT_BATCH_MAX over the task
// hooks.
static void plStepLbsLevel( plSceneData* s, const uint32_t* live, uint32_t live_count, const plFrameInput* inputs )
{
	uint32_t count = 0;
	for ( uint32_t m = 0; m < live_count; ++m )
	{
		if ( s->result_index[m] == PLEAT_SCENE_NO_NETWORK )
		{
			s->lbs_members[count++] = m;
		}
	}
	plStepEntry entries[PLEAT_BATCH_MAX];
	plStepGroup g;
	for ( uint32_t k0 = 0; k0 < count; k0 += PLEAT_BATCH_MAX )
	{
		uint32_t k1 = count - k0 > PLEAT_BATCH_MAX ? k0 + PLEAT_BATCH_MAX : count;
		plStepGroup_Init( &g, s->ctx, s->tiers[0].asset, entries, 0, &s->ctx->runner, "plScene_Step" );
		for ( uint32_t k = k0; k < k1; ++k )
		{
			uint32_t id = live[s->lbs_members[k]];
			plSceneCharacter* c = &s->characters[id];
			plAddLbs( &g, c, &inputs[id], c->back_positions, c->back_normals );
		}
		plRunStepGroup( &g );
		for ( uint32_t k = k0; k < k1; ++k )
		{
			s->lbs_results[s->lbs_members[k]] = entries[k - k0].result;
		}
	}
}

// A network detail's last outputs (its tier's instance, just stepped) on the display mesh.
static void plShowTier( const plSceneData* s, const plSceneCharacter* c, int32_t tier, float* positions, float* normals )
{
	const float *p, *n;
	plInstance_GetPositions( c->instances[tier], &p, NULL );
	plInstance_GetNormals( c->instances[tier], &n, NULL );
	const plSceneTier* t = &s->tiers[tier];
	if ( t->same_mesh )
	{
		memcpy( positions, p, (size_t)s->display_vertex_count * 12 );
		memcpy( normals, n, (size_t)s->display_vertex_count * 12 );
		return;
	}
	plTierTransfer_Apply( t->triangles, t->weights, t->offsets, s->display_vertex_count, p, n, positions, normals );
}

// The decay per frame of a character's recent motion (a half-life of ~70 frames).
#define PLEAT_MOTION_DECAY 0.99f

// The largest per-vertex distance between two [n][3] arrays over every stride-th vertex (metres).
static float plLargestJump( const float* a, const float* b, uint32_t n, uint32_t stride )
{
	float worst = 0.0f;
	for ( uint32_t v = 0; v < n; v += stride )
	{
		float dx = a[v * 3] - b[v * 3], dy = a[v * 3 + 1] - b[v * 3 + 1], dz = a[v * 3 + 2] - b[v * 3 + 2];
		float d = dx * dx + dy * dy + dz * dz;
		worst = d > worst ? d : worst;
	}
	return sqrtf( worst );
}

// One frame of a cross-fade: old detail in fade_positions/normals, new in back_positions/normals, last frame's outputs
// in positions. The new detail's weight α grows as fast as it can while the blended outputs move no vertex further
// from the last frame than the character's recent motion (or than the old detail alone moves this frame): per vertex
// |a + α b| <= R with a = old − last, b = new − old is a quadratic in α, and the largest α every vertex allows is
// taken — at most 1 / crossfade_frames more than the last frame's, at least a sixteenth of that (so a fade ends within
// 16 × crossfade_frames frames even while the character keeps moving as fast as it ever did). Normals blend and
// renormalise.
static void plCrossFade( const plSceneData* s, plSceneCharacter* c, const float* fade_positions,
						 const float* fade_normals )
{
	uint32_t n0 = s->display_vertex_count;
	float step = 1.0f / (float)s->crossfade_frames;
	float lo = fminf( 1.0f, c->fade_alpha + step / 16.0f ), hi = fminf( 1.0f, c->fade_alpha + step );
	float alpha = c->fade_alpha;
	// R: the recent motion, or the old detail's own jump with the weight kept where it was.
	float r2 = c->motion_m * c->motion_m;
	for ( uint32_t v = 0; v < n0; ++v )
	{
		float d2 = 0.0f;
		for ( int j = 0; j < 3; ++j )
		{
			float o = fade_positions[v * 3 + j], nw = c->back_positions[v * 3 + j];
			float d = o + alpha * ( nw - o ) - c->positions[v * 3 + j];
			d2 += d * d;
		}
		r2 = d2 > r2 ? d2 : r2;
	}
	float best = hi;
	for ( uint32_t v = 0; v < n0 && best > lo; ++v )
	{
		float a[3], b[3];
		for ( int j = 0; j < 3; ++j )
		{
			a[j] = fade_positions[v * 3 + j] - c->positions[v * 3 + j];
			b[j] = c->back_positions[v * 3 + j] - fade_positions[v * 3 + j];
		}
		float qa = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
		float qb = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
		float qc = a[0] * a[0] + a[1] * a[1] + a[2] * a[2] - r2;
		if ( qa <= 0.0f )
		{
			continue;
		}
		float disc = qb * qb - qa * qc;
		float root = disc > 0.0f ? ( -qb + sqrtf( disc ) ) / qa : alpha; // the largest α with |a + α b| <= R
		best = root < best ? root : best;
	}
	alpha = best < lo ? lo : ( best > hi ? hi : best );
	for ( uint32_t v = 0; v < n0; ++v )
	{
		float* p = c->back_positions + (size_t)v * 3;
		float* nv = c->back_normals + (size_t)v * 3;
		const float* fp = fade_positions + (size_t)v * 3;
		const float* fn = fade_normals + (size_t)v * 3;
		float n[3];
		for ( int j = 0; j < 3; ++j )
		{
			p[j] = fp[j] + alpha * ( p[j] - fp[j] );
			n[j] = fn[j] + alpha * ( nv[j] - fn[j] );
		}
		float length = sqrtf( n[0] * n[0] + n[1] * n[1] + n[2] * n[2] );
		for ( int j = 0; j < 3; ++j )
		{
			nv[j] = length > 0.0f ? n[j] / length : 0.0f;
		}
	}
	c->fade_alpha = alpha >= 1.0f ? 1.0f : alpha;
}

static plResult plCheckOutput( const plStepOutput* o, uint32_t vertex_count )
{
	uint32_t ps = o->position_stride_bytes != 0 ? o->position_stride_bytes : 12;
	uint32_t ns = o->normal_stride_bytes != 0 ? o->normal_stride_bytes : 12;
	if ( ( ps & 3u ) != 0 || ps < 12 || ( ns & 3u ) != 0 || ns < 12 || ( (uintptr_t)o->positions & 3u ) != 0 ||
		 ( (uintptr_t)o->normals & 3u ) != 0 )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	return ( o->positions != NULL || o->normals != NULL ) && o->vertex_capacity < vertex_count
			   ? PLEAT_RESULT_BUFFER_TOO_SMALL
			   : PLEAT_RESULT_OK;
}

static void plWriteOut( float* dst, uint32_t stride_bytes, const float* src, uint32_t vertex_count )
{
	if ( dst == NULL )
	{
		return;
	}
	uint32_t stride = stride_bytes != 0 ? stride_bytes : 12;
	for ( uint32_t v = 0; v < vertex_count; ++v )
	{
		float* d = (float*)( (uint8_t*)dst + (size_t)v * stride );
		d[0] = src[v * 3 + 0], d[1] = src[v * 3 + 1], d[2] = src[v * 3 + 2];
	}
}

// After the crowd step: one character's new outputs (its network's, or LBS-only), the cross-fade if one is in flight,
// its recent motion, the buffer swap and the copy out. fade_*: the calling worker's scratch.
static plResult plFinishCharacter( const plSceneData* s, plSceneCharacter* c, const plFrameInput* input,
								   const plStepOutput* out, uint32_t result_index, plResult lbs_result,
								   float* fade_positions, float* fade_normals )
{
	uint32_t n0 = s->display_vertex_count;
	int32_t tier = plLevelTier( s, c->level );
	int fade = c->fade_alpha < 1.0f;
	int32_t from = fade ? plLevelTier( s, c->fade_from ) : -1;
	// An LBS-only character's outputs are already in its back buffers (plStepLbsLevel); a network's are its tier's.
	plResult result = tier >= 0 ? s->step_results[result_index] : lbs_result;
	uint32_t joints = s->tiers[0].asset->joint_count;
	if ( result >= 0 && tier < 0 )
	{
		memcpy( c->skin_matrices, plGetInstanceData( c->instances[0] )->next_skin_matrices,
				(size_t)joints * 12 * sizeof( float ) );
	}
	else if ( result >= 0 )
	{
		plShowTier( s, c, tier, c->back_positions, c->back_normals );
		plInstance_GetSkinMatrices( c->instances[tier], c->skin_matrices, joints );
	}
	if ( result >= 0 && fade )
	{
		plResult rf = from < 0 ? plStepLbs( s, c, input, fade_positions, fade_normals ) : PLEAT_RESULT_OK;
		if ( from >= 0 )
		{
			plShowTier( s, c, from, fade_positions, fade_normals );
		}
		if ( rf >= 0 )
		{
			plCrossFade( s, c, fade_positions, fade_normals );
		}
	}
	else if ( result >= 0 && c->stepped )
	{
		c->motion_m = fmaxf( plLargestJump( c->back_positions, c->positions, n0, 2 ), c->motion_m * PLEAT_MOTION_DECAY );
	}
	if ( result >= 0 )
	{
		float* swap = c->positions;
		c->positions = c->back_positions, c->back_positions = swap;
		swap = c->normals;
		c->normals = c->back_normals, c->back_normals = swap;
		c->stepped = 1;
		c->frames_since_switch += c->frames_since_switch < UINT32_MAX / 2 ? 1u : 0u;
		if ( out != NULL )
		{
			plWriteOut( out->positions, out->position_stride_bytes, c->positions, n0 );
			plWriteOut( out->normals, out->normal_stride_bytes, c->normals, n0 );
		}
	}
	return result;
}

typedef struct plSceneFinishTask
{
	plSceneData* scene;
	const uint32_t* live;
	const plFrameInput* inputs;
	const plStepOutput* outputs;
} plSceneFinishTask;

// plTaskFn over the live characters: each verdict that let its character step becomes that character's result.
static void plFinishCharacters( uint32_t start, uint32_t end, uint32_t worker, void* context )
{
	const plSceneFinishTask* task = (const plSceneFinishTask*)context;
	plSceneData* s = task->scene;
	size_t display = (size_t)s->display_vertex_count * 3;
	float* fade_positions = s->fade_positions + (size_t)worker * 2 * display;
	for ( uint32_t m = start; m < end; ++m )
	{
		if ( s->result_index[m] == PLEAT_SCENE_SKIPPED )
		{
			continue;
		}
		uint32_t id = task->live[m];
		s->verdicts[m] = plFinishCharacter( s, &s->characters[id], &task->inputs[id],
											task->outputs != NULL ? &task->outputs[id] : NULL, s->result_index[m],
											s->lbs_results[m], fade_positions, fade_positions + display );
	}
}

plResult plScene_Step( plScene handle, const plFrameInput* inputs, const plStepOutput* outputs, plResult* out_results,
					   uint32_t count )
{
	plSceneData* s = plGetSceneData( handle );
	if ( s == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	uint32_t live_count = 0, highest = 0;
	uint32_t* live = s->live_ids;
	for ( uint32_t i = 0; i < s->capacity; ++i )
	{
		if ( s->characters[i].live )
		{
			live[live_count++] = i;
			highest = i;
		}
	}
	if ( live_count > 0 && ( inputs == NULL || count <= highest ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	uint32_t n0 = s->display_vertex_count;
	s->plan.switches = 0;
	plResult r = plPlan( s, live, live_count );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	// Switches first (the planned details are what this frame shows), then one crowd step for every network detail.
	uint32_t steps = 0;
	for ( uint32_t m = 0; m < live_count; ++m )
	{
		plSceneCharacter* c = &s->characters[live[m]];
		// Output spans are checked before anything steps: a character with bad spans changes in nothing.
		s->verdicts[m] = outputs != NULL ? plCheckOutput( &outputs[live[m]], n0 ) : PLEAT_RESULT_OK;
		if ( s->verdicts[m] != PLEAT_RESULT_OK )
		{
			continue;
		}
		if ( s->planned[m] != c->level || !c->stepped )
		{
			plSwitch( s, c, s->planned[m] );
		}
		int32_t tier = plLevelTier( s, c->level );
		int32_t from = c->fade_alpha < 1.0f ? plLevelTier( s, c->fade_from ) : -1;
		if ( tier >= 0 )
		{
			s->step_instances[steps] = c->instances[tier];
			s->step_inputs[steps++] = inputs[live[m]];
		}
		if ( from >= 0 && from != tier )
		{
			s->step_instances[steps] = c->instances[from];
			s->step_inputs[steps++] = inputs[live[m]];
		}
	}
	plStepInstances( handle.context, s->step_instances, s->step_inputs, NULL, s->step_results, steps );

	// Each character's outputs are finished apart from the others' (its own instances and buffers, a worker's own
	// scratch), so the host's workers share them; the verdicts become the characters' results.
	uint32_t k = 0;
	for ( uint32_t m = 0; m < live_count; ++m )
	{
		plSceneCharacter* c = &s->characters[live[m]];
		s->result_index[m] = PLEAT_SCENE_SKIPPED;
		if ( s->verdicts[m] != PLEAT_RESULT_OK )
		{
			continue;
		}
		int32_t tier = plLevelTier( s, c->level );
		int32_t from = c->fade_alpha < 1.0f ? plLevelTier( s, c->fade_from ) : -1;
		s->result_index[m] = tier >= 0 ? k : PLEAT_SCENE_NO_NETWORK;
		// and the fading-out detail's result right after it (the same input, so the same verdict)
		k += ( tier >= 0 ) + ( from >= 0 && from != tier );
	}
	plStepLbsLevel( s, live, live_count, inputs );
	plSceneFinishTask finish = { s, live, inputs, outputs };
	plRunTask( &s->ctx->runner, plFinishCharacters, live_count, 2, &finish );

	plResult first_error = PLEAT_RESULT_OK, first_note = PLEAT_RESULT_OK;
	uint32_t fading = 0;
	double weighted_error = 0.0, importance = 0.0;
	for ( uint32_t m = 0; m < live_count; ++m )
	{
		uint32_t id = live[m];
		const plSceneCharacter* c = &s->characters[id];
		plResult result = s->verdicts[m];
		if ( out_results != NULL )
		{
			out_results[id] = result;
		}
		first_error = first_error == PLEAT_RESULT_OK && result < 0 ? result : first_error;
		first_note = first_note == PLEAT_RESULT_OK && result > 0 ? result : first_note;
		if ( s->result_index[m] == PLEAT_SCENE_SKIPPED )
		{
			continue; // its output spans were rejected: it did not step
		}
		fading += c->fade_alpha < 1.0f;
		weighted_error += (double)c->importance * s->levels[c->level].error_mm;
		importance += c->importance;
	}
	s->plan.fading = fading;
	s->plan.weighted_error_mm = importance > 0.0 ? (float)( weighted_error / importance ) : 0.0f;
	return first_error != PLEAT_RESULT_OK ? first_error : first_note;
}
