// The per-instance stages of a step (docs/architecture.md draws them), the single-stream form of each:
//
//     validate → network rate decision → forward kinematics → [ input assembly X_c → input normalisation → f_LP →
//     latent guard → f_dec ] → blend shapes T_def → skinning x' → normals n → commit
//
// with the bracket only on steps where the networks run (network_rate.c). step.c runs them as one stage list for a
// group of instances — plInstance_Step is a group of one — and swaps in the wide forms of the networks, blend and
// geometry (step_lanes.c) for a crowd. Everything is checked before anything changes; the jobs write scratch
// (next_*), and the commit is the only place the instance's history, latent and weights change. A non-finite value
// inside the step is a numeric reset: the step is recomputed as a first frame with a zero latent, and if even that is
// non-finite the body is dressed without the learned deformation. The numpy twin, tools/pleat/reference/instance.py,
// has the same functions in the same order.
#include "instance.h"
#include "core/step_phases.h"

#include <math.h>
#include <string.h>

// ---- validate: arguments, then the pose (non-finite, quaternion lengths, dt), as the numpy reference ----

static int plValidQuatLength( const double q[4], double* out_length )
{
	double length = sqrt( q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] );
	*out_length = length;
	return fabs( length - 1.0 ) <= 1e-3;
}

static plResult plValidateOutput( const plStepOutput* output, uint32_t vertex_count )
{
	if ( output == NULL )
	{
		return PLEAT_RESULT_OK;
	}
	uint32_t ps = output->position_stride_bytes != 0 ? output->position_stride_bytes : 12;
	uint32_t ns = output->normal_stride_bytes != 0 ? output->normal_stride_bytes : 12;
	if ( ( ( ps & 3u ) != 0 || ps < 12 ) || ( ( ns & 3u ) != 0 || ns < 12 ) ||
		 ( output->positions != NULL && ( (uintptr_t)output->positions & 3u ) != 0 ) ||
		 ( output->normals != NULL && ( (uintptr_t)output->normals & 3u ) != 0 ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( ( output->positions != NULL || output->normals != NULL ) && output->vertex_capacity < vertex_count )
	{
		return PLEAT_RESULT_BUFFER_TOO_SMALL;
	}
	return PLEAT_RESULT_OK;
}

// Checks the step's arguments in the documented order (pleat.h, plInstance_Step) and gathers the pose into asset
// joint order. Changes nothing in the instance.
plResult plValidateStep( const plInstanceData* inst, const plFrameInput* input, const plStepOutput* output,
								plStepPose* pose )
{
	const plAssetData* a = inst->asset;
	const plContextData* ctx = inst->ctx;
	if ( input == NULL || input->joint_rotations == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plResult r = plValidateOutput( output, a->vertex_count );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	uint32_t stride = input->joint_stride_bytes != 0 ? input->joint_stride_bytes : 16;
	if ( stride < 16 || ( stride & 3u ) != 0 || ( (uintptr_t)input->joint_rotations & 3u ) != 0 )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( input->joint_count != inst->engine_joint_count )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_INPUT, "joint_count %u, expected %u",
			   input->joint_count, inst->engine_joint_count );
		return PLEAT_RESULT_JOINT_COUNT_MISMATCH;
	}

	// Gather and check the pose: non-finite first, then quaternion lengths, then dt (as the numpy reference).
	double( *quats )[4] = pose->joint_quats;
	for ( uint32_t j = 0; j < a->joint_count; ++j )
	{
		int32_t e = inst->joint_map[j];
		if ( e < 0 )
		{
			quats[j][0] = quats[j][1] = quats[j][2] = 0.0;
			quats[j][3] = 1.0;
			continue;
		}
		const float* q = (const float*)( (const uint8_t*)input->joint_rotations + (size_t)e * stride );
		for ( int c = 0; c < 4; ++c )
		{
			quats[j][c] = q[c];
		}
	}
	double* root_q = pose->root_rotation;
	double* root_t = pose->root_translation;
	root_q[0] = input->root_rotation.x;
	root_q[1] = input->root_rotation.y;
	root_q[2] = input->root_rotation.z;
	root_q[3] = input->root_rotation.w;
	root_t[0] = input->root_translation.x;
	root_t[1] = input->root_translation.y;
	root_t[2] = input->root_translation.z;
	int finite = isfinite( input->dt_s ) && isfinite( root_t[0] ) && isfinite( root_t[1] ) && isfinite( root_t[2] );
	for ( int c = 0; c < 4; ++c )
	{
		finite = finite && isfinite( root_q[c] );
	}
	for ( uint32_t j = 0; j < a->joint_count && finite; ++j )
	{
		for ( int c = 0; c < 4; ++c )
		{
			finite = finite && isfinite( quats[j][c] );
		}
	}
	if ( !finite )
	{
		// Name the first offender in the engine's joint numbering: that is the array the engine filled.
		int32_t bad_engine_joint = -1;
		for ( uint32_t j = 0; j < a->joint_count && bad_engine_joint < 0; ++j )
		{
			for ( int c = 0; c < 4; ++c )
			{
				bad_engine_joint = isfinite( quats[j][c] ) ? bad_engine_joint : inst->joint_map[j];
			}
		}
		if ( bad_engine_joint >= 0 )
		{
			plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_INPUT, "engine joint %d rotation is not finite",
				   (int)bad_engine_joint );
		}
		else
		{
			plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_INPUT, "non-finite root or dt" );
		}
		return PLEAT_RESULT_NON_FINITE_INPUT;
	}
	if ( root_q[0] == 0.0 && root_q[1] == 0.0 && root_q[2] == 0.0 && root_q[3] == 0.0 )
	{
		root_q[3] = 1.0;
	}
	double length;
	for ( uint32_t j = 0; j < a->joint_count; ++j )
	{
		if ( !plValidQuatLength( quats[j], &length ) )
		{
			// The engine's index (what it filled joint_rotations by), with the asset joint it drives for context.
			plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_INPUT,
				   "engine joint %d (asset joint %u '%s') quaternion length %g", (int)inst->joint_map[j], j,
				   a->joint_names + (size_t)j * PLEAT_JOINT_NAME_SIZE, length );
			return PLEAT_RESULT_INVALID_QUATERNION;
		}
		for ( int c = 0; c < 4; ++c )
		{
			quats[j][c] /= length;
		}
	}
	if ( !plValidQuatLength( root_q, &length ) )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_INPUT, "root quaternion length %g", length );
		return PLEAT_RESULT_INVALID_QUATERNION;
	}
	for ( int c = 0; c < 4; ++c )
	{
		root_q[c] /= length;
	}
	if ( !( input->dt_s > 0.0f ) || input->dt_s > 1.0f )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_INPUT, "dt_s %g outside (0, 1]", input->dt_s );
		return PLEAT_RESULT_INVALID_DT;
	}
	return PLEAT_RESULT_OK;
}

int plWantsReadBack( const plInstanceData* inst, const plStepOutput* output )
{
	return inst->gl == NULL || inst->read_back_always ||
		   ( output != NULL && ( output->positions != NULL || output->normals != NULL ) );
}

// ---- forward kinematics: frame t+1 into the scratch frame and the scratch skinning matrices ----

plResult plRunForwardKinematics( plInstanceData* inst, const plStepPose* pose, double dt_s, double previous_yaw )
{
	const plAssetData* a = inst->asset;
	plPoseFrame* now = &inst->next_frame;
	for ( uint32_t j = 0; j < a->joint_count; ++j )
	{
		plQuatToMatrix( pose->joint_quats[j], now->local_rotations[j] );
	}
	double root_rotation[9];
	plQuatToMatrix( pose->root_rotation, root_rotation );
	plForwardKinematicsJob fk = { a->parents,          a->joint_count, inst->rest_joints,
								  pose->root_translation, root_rotation,  previous_yaw,
								  dt_s,                now,            inst->next_skin_matrices };
	if ( plForwardKinematicsJob_Run( &fk ) != PLEAT_RESULT_OK )
	{
		return PLEAT_RESULT_INTERNAL_ERROR;
	}
	PLEAT_STEP_PHASE( PLEAT_PHASE_FK );
	return PLEAT_RESULT_OK;
}

// ---- the networks: X_c → x → f_LP → Z_t+1 → f_dec → w ----

// f_LP or f_dec on the instance's backend: ONNX Runtime when the def chose it, else the MLP job.
static plResult plRunNetwork( plInstanceData* inst, plOrtMlp* ort, const plLayer* layers, uint32_t layer_count,
							  uint32_t activation, const float* input, uint32_t input_count, float* output,
							  uint32_t output_count )
{
	if ( ort != NULL )
	{
		return plOrtMlp_Run( ort, input, output ); // ONNX Runtime's own error: passed on as it is
	}
	plMlpJob mlp = { layers,
					 layer_count,
					 activation,
					 plMakeConstSpan( input, input_count, 4 ),
					 plMakeSpan( output, output_count, 4 ),
					 plMakeSpan( inst->mlp_scratch, inst->mlp_scratch_count, 4 ),
					 &inst->ctx->kernels,
					 &inst->ctx->runner };
	return plMlpJob_Run( &mlp ) == PLEAT_RESULT_OK ? PLEAT_RESULT_OK : PLEAT_RESULT_INTERNAL_ERROR;
}

plResult plAssembleNetworkInput( plInstanceData* inst, const plPoseFrame* frame_t, const plPoseFrame* frame_tm1,
								 const float* latent )
{
	const plAssetData* a = inst->asset;
	const plPoseFrame* now = &inst->next_frame;
	plInputAssemblyJob assembly = { { now, frame_t != NULL ? frame_t : now, frame_tm1 != NULL ? frame_tm1 : now },
									latent,
									a->latent_count,
									a->input_joints,
									a->input_joint_count,
									inst->beta,
									a->beta_count,
									inst->material_normalized,
									plMakeSpan( inst->x, a->input_count, 4 ) };
	plInputNormalisationJob normalisation = { plMakeConstSpan( inst->x, a->input_count, 4 ), a->x_mean, a->x_std,
											  plMakeSpan( inst->x, a->input_count, 4 ) };
	if ( plInputAssemblyJob_Run( &assembly ) != PLEAT_RESULT_OK ||
		 plInputNormalisationJob_Run( &normalisation ) != PLEAT_RESULT_OK )
	{
		return PLEAT_RESULT_INTERNAL_ERROR;
	}
	PLEAT_STEP_PHASE( PLEAT_PHASE_INPUT );
	return PLEAT_RESULT_OK;
}

plResult plGuardLatent( plInstanceData* inst )
{
	const plAssetData* a = inst->asset;
	plLatentGuardJob guard = { plMakeConstSpan( inst->y, a->latent_count, 4 ),
							   a->z_mean,
							   a->z_std,
							   a->z_min,
							   a->z_max,
							   plMakeSpan( inst->next_latent, a->latent_count, 4 ) };
	return plLatentGuardJob_Run( &guard ) == PLEAT_RESULT_OK ? PLEAT_RESULT_OK : PLEAT_RESULT_INTERNAL_ERROR;
}

plResult plRunNetworks( plInstanceData* inst, int* out_finite )
{
	const plAssetData* a = inst->asset;
	*out_finite = 0;
	plResult r = plRunNetwork( inst, inst->ort_lp, a->lp, a->lp_layer_count, a->lp_activation, inst->x,
							   a->input_count, inst->y, a->latent_count );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	PLEAT_STEP_PHASE( PLEAT_PHASE_LP );
	if ( !plAllFiniteFloats( inst->y, a->latent_count ) )
	{
		return PLEAT_RESULT_OK; // before the guard: its clamp would turn an overflow into a bound
	}
	PLEAT_STEP_PHASE( PLEAT_PHASE_GUARDS );
	r = plGuardLatent( inst );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	r = plRunNetwork( inst, inst->ort_dec, a->dec, a->dec_layer_count, a->dec_activation, inst->next_latent,
					  a->latent_count, inst->next_weights, a->blend_count );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	PLEAT_STEP_PHASE( PLEAT_PHASE_DEC );
	*out_finite = plAllFiniteFloats( inst->next_weights, a->blend_count ) &&
				  plAllFiniteFloats( inst->next_skin_matrices, (size_t)a->joint_count * 12 );
	PLEAT_STEP_PHASE( PLEAT_PHASE_GUARDS );
	return PLEAT_RESULT_OK;
}

// ---- the deformation: T_def → x' → n for next_weights and next_skin_matrices ----

int plBeginBlend( plInstanceData* inst, int networks_ran )
{
	if ( !networks_ran )
	{
		memcpy( inst->next_weights, inst->blend_weights, inst->asset->blend_count * sizeof( float ) );
	}
	int blend = networks_ran || !inst->deformed_is_committed;
	if ( blend )
	{
		inst->deformed_is_committed = 0; // until this step commits
	}
	return blend;
}

plResult plDeform( plInstanceData* inst, int blend, int read_back, const plTaskRunner* runner, int* out_finite )
{
	const plAssetData* a = inst->asset;
	*out_finite = 1;
	if ( inst->gl != NULL )
	{
		// Read back into scratch: the commit copies it to positions/normals only once nothing can fail any more, so a
		// GL error leaves the instance's buffers as they were.
		return plGlDeformer_Run( inst->gl, inst->next_weights, inst->next_skin_matrices,
								 read_back ? inst->deformed : NULL, read_back ? inst->gl_normals : NULL );
	}
	plDeformSpans spans = { inst->next_weights, inst->next_skin_matrices, blend, inst->deformed,
							inst->positions,    inst->normals,            0 };
	plResult r = plDeformCpu( inst, &spans, runner );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	size_t n3 = (size_t)a->vertex_count * 3;
	*out_finite = plAllFiniteFloats( inst->positions, n3 ) && plAllFiniteFloats( inst->normals, n3 );
	PLEAT_STEP_PHASE( PLEAT_PHASE_GUARDS );
	return PLEAT_RESULT_OK;
}

// ---- the numeric reset ----

// Z_t+1 into next_latent and w into next_weights as a first frame (frame t+1 stands in for t and t−1) from latent.
// *out_finite = 0 if f_LP's output, the weights or the skinning matrices are not all finite.
static plResult plEvaluateFirstFrame( plInstanceData* inst, const float* latent, int* out_finite )
{
	*out_finite = 0;
	plResult r = plAssembleNetworkInput( inst, NULL, NULL, latent );
	return r == PLEAT_RESULT_OK ? plRunNetworks( inst, out_finite ) : r;
}

// Frame t+1 recomputed as a first frame (no history, previous yaw 0) with a zero latent. The instance's own latent and
// history stay untouched until the commit (a GL error after this point must still change nothing); next_latent is the
// zero input latent (input assembly reads it before the guard overwrites it). If the networks give nothing usable
// even from there — non-finite, or an ONNX Runtime error, which is not returned because the first attempt may already
// have left non-finite positions on the CPU path — the body is dressed without the learned deformation: zero latent
// and weights.
plResult plStepFromReset( plInstanceData* inst, const plStepPose* pose, double dt_s, int read_back )
{
	const plAssetData* a = inst->asset;
	const plTaskRunner* runner = &inst->ctx->runner;
	memset( inst->next_latent, 0, a->latent_count * sizeof( float ) );
	plResult r = plRunForwardKinematics( inst, pose, dt_s, 0.0 );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	int finite = 0;
	r = plEvaluateFirstFrame( inst, inst->next_latent, &finite );
	if ( r == PLEAT_RESULT_INTERNAL_ERROR )
	{
		return r;
	}
	if ( r == PLEAT_RESULT_OK && finite )
	{
		r = plDeform( inst, plBeginBlend( inst, 1 ), read_back, runner, &finite );
		if ( r != PLEAT_RESULT_OK )
		{
			return r;
		}
	}
	else
	{
		finite = 0;
	}
	if ( !finite )
	{
		memset( inst->next_latent, 0, a->latent_count * sizeof( float ) );
		memset( inst->next_weights, 0, a->blend_count * sizeof( float ) );
		// committed even if non-finite: there is nothing further back
		return plDeform( inst, plBeginBlend( inst, 1 ), read_back, runner, &finite );
	}
	return PLEAT_RESULT_OK;
}

// ---- commit ----

static void plCopyOut( float* dst, uint32_t stride_bytes, const float* src, uint32_t vertex_count )
{
	if ( dst == NULL )
	{
		return;
	}
	uint32_t stride = stride_bytes != 0 ? stride_bytes : 12;
	uint8_t* d = (uint8_t*)dst;
	for ( uint32_t v = 0; v < vertex_count; ++v )
	{
		float* p = (float*)( d + (size_t)v * stride );
		p[0] = src[v * 3 + 0];
		p[1] = src[v * 3 + 1];
		p[2] = src[v * 3 + 2];
	}
}

// After a network update: t−1 ← t (or t+1 on a first frame or after a reset), t ← t+1, Z_t ← Z_t+1, w ← w_next.
// Between updates only the pose-dependent outputs change, and the time since the update grows.
void plCommit( plInstanceData* inst, int networks_ran, int reset, float dt_s, int read_back,
					  const plStepOutput* output )
{
	const plAssetData* a = inst->asset;
	if ( networks_ran )
	{
		// A first frame (or one after a reset) runs whatever the interval says; the next update the interval decides
		// is the one that comes early by the lead, and takes it up.
		inst->network_lead_s = inst->history_valid && !reset ? 0.0 : inst->network_lead_s;
		inst->history[1] = inst->history_valid && !reset ? inst->history[0] : inst->next_frame;
		inst->history[0] = inst->next_frame;
		inst->history_valid = 1;
		inst->network_pending_s = 0.0;
		memcpy( inst->latent, inst->next_latent, a->latent_count * sizeof( float ) );
		memcpy( inst->blend_weights, inst->next_weights, a->blend_count * sizeof( float ) );
	}
	else
	{
		inst->network_pending_s += dt_s;
	}
	inst->deformed_is_committed = inst->gl == NULL;
	memcpy( inst->skin_matrices, inst->next_skin_matrices, (size_t)a->joint_count * 12 * sizeof( float ) );
	if ( inst->gl != NULL && read_back )
	{
		memcpy( inst->positions, inst->deformed, (size_t)a->vertex_count * 3 * sizeof( float ) );
		memcpy( inst->normals, inst->gl_normals, (size_t)a->vertex_count * 3 * sizeof( float ) );
	}
	if ( output != NULL && read_back )
	{
		plCopyOut( output->positions, output->position_stride_bytes, inst->positions, a->vertex_count );
		plCopyOut( output->normals, output->normal_stride_bytes, inst->normals, a->vertex_count );
	}
	PLEAT_STEP_PHASE( PLEAT_PHASE_COMMIT );
}

plResult plStepResult( const plInstanceData* inst, int reset, const plNetworkUpdate* update, float dt_s )
{
	if ( reset )
	{
		plLog( inst->ctx, PLEAT_LOG_LEVEL_WARNING, PLEAT_LOG_INSTANCE_NUMERIC_RESET, NULL );
		return PLEAT_RESULT_NUMERIC_RESET;
	}
	if ( update->dt_clamped )
	{
		plLog( inst->ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_INSTANCE_INPUT_CLAMPED, "dt_s %g", dt_s );
		return PLEAT_RESULT_CLAMPED;
	}
	return PLEAT_RESULT_OK;
}
