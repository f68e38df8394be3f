// plScene_Step (pleat.h, SCENE BUDGET; docs/scene-budget.md): the budget policy's plan, the switches, one
// plStepInstances call for every network detail shown, the LBS-only level (a step group with the networks off,
// step.h) and the characters finished over the task hooks.
//
// A switch resets the new tier's instance (its latent restarts from zero, its history from the new pose), which is
// stepped from then on. While a switch fades, the old detail is stepped as well and the outputs blend from old to new
// over crossfade_frames frames, so the largest per-vertex jump of a switch is the gap between the two details divided
// over the fade, on top of the frame's own motion (test_tier_switch_does_not_pop). LBS-only skins tiers[0]'s shaped
// template with the frame's skinning matrices, without touching the instance's history.
#include "scene.h"
#include "step/step.h"

#include <math.h>
#include <string.h>

// The share of the budget a plan may fill: 5 % headroom for the frame-to-frame spread of the costs (a reduced network
// rate makes one frame in k heavier) and for the lag of the cost correction (plScene_ReportFrameCost).
#define PLEAT_SCENE_BUDGET_SHARE 0.9f

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
		s->extra_gpu_cost_us[m] = fading ? s->levels[c->fade_from].gpu_cost_us : 0.0f;
	}
	float cost = 0.0f, gpu_cost = 0.0f;
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
							 &cost,
							 s->gpu_frontier,
							 s->gpu_frontier_count,
							 s->gpu_budget_us > 0.0f ? PLEAT_SCENE_BUDGET_SHARE * s->gpu_budget_us : INFINITY,
							 s->gpu_mode != PLEAT_GPU_MODE_NONE ? plSceneGpuWeight( s ) : 0.0f,
							 s->extra_gpu_cost_us,
							 &gpu_cost };
	plResult r = plSceneBudgetJob_Run( &job );
	s->model_cost_us = cost;
	s->plan.cost_us = cost * s->cost_scale;
	s->plan.cost_scale = s->cost_scale;
	s->plan.budget_us = s->budget_us;
	s->plan.gpu_cost_us = gpu_cost;
	s->plan.gpu_budget_us = s->gpu_budget_us;
	s->plan.on_gpu = 0;
	for ( uint32_t m = 0; m < live_count; ++m )
	{
		s->plan.on_gpu += s->levels[s->planned[m]].gpu != 0;
	}
	return r == PLEAT_RESULT_OK ? PLEAT_RESULT_OK : PLEAT_RESULT_INTERNAL_ERROR;
}

// A character takes its planned level: a rate change in place; any other change restarts the new detail and fades.
// At a reduced network rate, the character's first update after a switch comes early by its own share of the
// interval (the golden-ratio sequence over character slots): characters that switch together — all of them on the
// first frame — then run their networks on different frames instead of all on one, so the frames cost alike and
// the engine sees no spike every 1 / rate. The networks see the true time since their last update.
static void plStaggerNetworkUpdates( const plSceneData* s, const plSceneCharacter* c, int32_t slot, float rate_hz )
{
	if ( rate_hz <= 0.0f )
	{
		return;
	}
	double share = fmod( (double)( c - s->characters ) * 0.6180339887498949, 1.0 );
	plInstanceData* inst = plGetInstanceData( c->instances[slot] );
	inst->network_lead_s = share * inst->network_interval_s;
}

static void plSwitch( plSceneData* s, plSceneCharacter* c, uint32_t target )
{
	int32_t from_slot = plLevelSlot( s, c->level ), to_slot = plLevelSlot( s, target );
	float rate = s->levels[target].rate_hz;
	s->plan.switches += 1;
	c->frames_since_switch = 0;
	if ( to_slot >= 0 && from_slot == to_slot && c->stepped )
	{
		plInstance_SetNetworkRate( c->instances[to_slot], rate );
		plStaggerNetworkUpdates( s, c, to_slot, rate );
		c->level = target;
		return;
	}
	if ( to_slot >= 0 )
	{
		// Another tier, or the same tier on the other device: a new detail, restarted and faded in.
		plInstance_Reset( c->instances[to_slot] );
		plInstance_SetNetworkRate( c->instances[to_slot], rate );
		plStaggerNetworkUpdates( s, c, to_slot, rate );
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

// A network detail's last outputs (its tier's instance on its device, slot, just stepped) on the display mesh.
static void plShowTier( const plSceneData* s, const plSceneCharacter* c, int32_t slot, float* positions, float* normals )
{
	const float *p, *n;
	plInstance_GetPositions( c->instances[slot], &p, NULL );
	plInstance_GetNormals( c->instances[slot], &n, NULL );
	const plSceneTier* t = &s->tiers[slot % PLEAT_MAX_TIERS];
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
	int32_t tier = plLevelSlot( s, c->level ); // the instance shown (−1: LBS-only)
	int fade = c->fade_alpha < 1.0f;
	int32_t from = fade ? plLevelSlot( s, c->fade_from ) : -1;
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
		int32_t tier = plLevelSlot( s, c->level ); // the instances shown and fading out
		int32_t from = c->fade_alpha < 1.0f ? plLevelSlot( s, c->fade_from ) : -1;
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
		int32_t tier = plLevelSlot( s, c->level );
		int32_t from = c->fade_alpha < 1.0f ? plLevelSlot( s, c->fade_from ) : -1;
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
