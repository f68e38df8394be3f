// The instance: one dressed character. Owns the pose history, the latent, the shaped template cache and every buffer
// a step needs (allocated once at creation). plInstance_Step validates everything first (an error changes nothing),
// then runs the jobs: forward kinematics → input assembly → f_LP → latent guard → f_dec → blend shapes → skinning →
// normals, and commits the new history and latent only at the end.
#include "asset.h"
#include "core.h"
#include "gl_deformer.h"
#include "jobs.h"
#include "ort_backend.h"
#include "skeleton.h"
#include "step_phases.h"

#include <math.h>
#include <string.h>

typedef struct plInstanceData
{
	plContextData* ctx;
	plAssetData* asset;
	plAsset asset_handle;
	void* user_data;

	int32_t joint_map[PLEAT_MAX_JOINTS]; // engine joint per asset joint, −1 = identity
	uint32_t engine_joint_count;

	float beta[PLEAT_MAX_BETAS];       // clamped β
	float material[4];                 // clamped (m, μ, λ, k)
	float material_normalized[4];      // (x − min) / (max − min)
	double rest_joints[PLEAT_MAX_JOINTS * 3]; // J(β)

	plPoseFrame history[2]; // frames t and t−1 (of the network: the frames at its last two updates)
	int history_valid;      // 0: the next step is a first frame
	plPoseFrame next_frame; // scratch for t+1

	double network_interval_s; // 1 / network_rate_hz; 0 = the networks run every step
	double network_pending_s;  // time since the last network update (steps that skipped it)
	int deformed_is_committed; // CPU path: deformed holds T_def of the committed blend weights and current β

	float skin_matrices[PLEAT_MAX_JOINTS * 12];      // last committed step
	float next_skin_matrices[PLEAT_MAX_JOINTS * 12]; // scratch

	// One block, 64-byte aligned sub-buffers.
	void* block;
	size_t block_size;
	float* shaped_template; // [N][3] T + G_S(β)
	float* latent;          // [L] Z_t
	float* next_latent;     // [L]
	float* x;               // [I] X_c, then normalised
	float* y;               // [L] raw f_LP output
	float* blend_weights;   // [D] last committed
	float* next_weights;    // [D]
	float* mlp_scratch;     // [2 · widest]
	uint32_t mlp_scratch_count;
	float* deformed;        // [N][3] T_def
	float* positions;       // [N][3]
	float* normals;         // [N][3]
	float* face_normals;    // [F][4] scratch: unnormalised face normals (x, y, z, 0)
	float* gl_normals;      // [N][3] GPU modes only: normals read back here (positions into deformed, unused on the
	                        // GPU path) and copied to normals/positions only when the whole step succeeded

	plOrtMlp* ort_lp;
	plOrtMlp* ort_dec;
	plGlDeformer* gl;
} plInstanceData;

static plInstanceData* plGetInstanceData( plInstance handle )
{
	plContextData* ctx = plGetContext( handle.context ); // the context generation too: its slot may have a new context
	if ( ctx == NULL )
	{
		return NULL;
	}
	return (plInstanceData*)plSlotTable_Get( &ctx->instances, handle.index1, handle.generation );
}

plInstanceDef plDefaultInstanceDef( void )
{
	plInstanceDef def;
	memset( &def, 0, sizeof( def ) );
	def.mlp_backend = PLEAT_MLP_BACKEND_PLEAT;
	def.gpu_mode = PLEAT_GPU_NONE;
	def.internal_cookie = PLEAT_DEF_COOKIE;
	return def;
}

// ---- shape and material ----

// Clamps β into inst->beta (missing entries 0). Returns 1 if something was clamped. Values must be finite.
static int plClampBeta( const plAssetData* a, const float* beta, uint32_t count, float* out )
{
	int clamped = 0;
	for ( uint32_t b = 0; b < a->beta_count; ++b )
	{
		float v = ( beta != NULL && b < count ) ? beta[b] : 0.0f;
		if ( v < a->beta_min )
		{
			v = a->beta_min;
			clamped = 1;
		}
		else if ( v > a->beta_max )
		{
			v = a->beta_max;
			clamped = 1;
		}
		out[b] = v;
	}
	return clamped;
}

static int plClampMaterial( const plAssetData* a, const float* material, float* out, float* out_normalized )
{
	int clamped = 0;
	for ( int i = 0; i < 4; ++i )
	{
		float v = material != NULL ? material[i] : a->material_default[i];
		if ( v < a->material_min[i] )
		{
			v = a->material_min[i];
			clamped = 1;
		}
		else if ( v > a->material_max[i] )
		{
			v = a->material_max[i];
			clamped = 1;
		}
		out[i] = v;
		out_normalized[i] = (float)( ( (double)v - a->material_min[i] ) / ( (double)a->material_max[i] - a->material_min[i] ) );
	}
	return clamped;
}

// T + Σ_b β_b G_S[b], accumulated in double in b order. out: [N][3].
static void plShapeTemplate( const plAssetData* a, const float* beta, float* out )
{
	size_t n3 = (size_t)a->vertex_count * 3;
	for ( size_t i = 0; i < n3; ++i )
	{
		double v = a->template_positions[i];
		for ( uint32_t b = 0; b < a->beta_count; ++b )
		{
			v += (double)beta[b] * a->shape_blend[b * n3 + i];
		}
		out[i] = (float)v;
	}
}

// J(β) = J_template + Σ_b β_b J_shapedirs[b], accumulated in double in b order. out: [J][3].
static void plShapeJoints( const plAssetData* a, const float* beta, double* out )
{
	size_t j3 = (size_t)a->joint_count * 3;
	for ( size_t i = 0; i < j3; ++i )
	{
		double v = a->joint_template[i];
		for ( uint32_t b = 0; b < a->beta_count; ++b )
		{
			v += (double)beta[b] * a->joint_shapedirs[b * j3 + i];
		}
		out[i] = v;
	}
}

// The shaped template and J(β) of inst->beta.
static void plApplyShape( plInstanceData* inst )
{
	plShapeTemplate( inst->asset, inst->beta, inst->shaped_template );
	plShapeJoints( inst->asset, inst->beta, inst->rest_joints );
}

// Exponent bits all ones = Inf or NaN. Branch-free over the whole array so the compiler vectorises it (it runs over
// the N·3 positions and normals every step).
static int plAllFiniteFloats( const float* v, size_t count )
{
	uint32_t non_finite = 0;
	for ( size_t i = 0; i < count; ++i )
	{
		uint32_t bits;
		memcpy( &bits, v + i, sizeof( bits ) );
		non_finite |= (uint32_t)( ( bits & 0x7F800000u ) == 0x7F800000u );
	}
	return non_finite == 0;
}

// ---- the deformation jobs, split over vertex ranges ----

typedef struct plDeformTask
{
	plInstanceData* inst;
	const float* weights;
	const float* skin_matrices;
	int blend; // 0: deformed already holds T_def for these weights (a step between network updates)
} plDeformTask;

static void plBlendAndSkinTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	const plDeformTask* t = (const plDeformTask*)context;
	plInstanceData* inst = t->inst;
	const plAssetData* a = inst->asset;
	uint32_t n = a->vertex_count;
	if ( t->blend )
	{
		plBlendShapesJob blend = { plMakeConstSpan( inst->shaped_template, n, 12 ), a->blend_shapes,
								   a->blend_shapes_fp16, plMakeConstSpan( t->weights, a->blend_count, 4 ),
								   plMakeSpan( inst->deformed, n, 12 ), begin, end, &inst->ctx->kernels };
		plBlendShapesJob_Run( &blend );
		PLEAT_STEP_PHASE( PLEAT_PHASE_BLEND );
	}
	plSkinningJob skin = { plMakeConstSpan( inst->deformed, n, 12 ), a->skin_indices, a->skin_weights,
						   a->influence_count, t->skin_matrices, a->joint_count, plMakeSpan( inst->positions, n, 12 ),
						   begin, end, &inst->ctx->kernels };
	plSkinningJob_Run( &skin );
	PLEAT_STEP_PHASE( PLEAT_PHASE_SKIN );
}

static void plNormalsTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	const plDeformTask* t = (const plDeformTask*)context;
	const plAssetData* a = t->inst->asset;
	plNormalsGatherJob job = { { plMakeConstSpan( t->inst->positions, a->vertex_count, 12 ), a->faces, a->face_count,
								 a->adjacency_offsets, a->adjacency_faces,
								 plMakeSpan( t->inst->normals, a->vertex_count, 12 ), begin, end },
							   t->inst->face_normals, &t->inst->ctx->kernels };
	plNormalsGatherJob_Run( &job );
	PLEAT_STEP_PHASE( PLEAT_PHASE_GATHER );
}

static void plFaceNormalsTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	const plDeformTask* t = (const plDeformTask*)context;
	const plAssetData* a = t->inst->asset;
	plFaceNormalsJob job = { plMakeConstSpan( t->inst->positions, a->vertex_count, 12 ), a->faces, a->face_count,
							 t->inst->face_normals, begin, end, &t->inst->ctx->kernels };
	plFaceNormalsJob_Run( &job );
	PLEAT_STEP_PHASE( PLEAT_PHASE_FACE_NORMALS );
}

static void plDeformCpu( plInstanceData* inst, const float* weights, const float* skin_matrices, int blend )
{
	const plTaskRunner* runner = &inst->ctx->runner;
	plDeformTask task = { inst, weights, skin_matrices, blend };
	const plAssetData* a = inst->asset;
	plRunTask( runner, plBlendAndSkinTask, a->vertex_count, 256, &task );
	if ( !plTaskRunner_IsParallel( runner ) && a->face_count >= a->vertex_count )
	{
		// One thread: one pass over the faces scattering into per-vertex sums (the face-normal scratch, [F][4] with
		// F ≥ N, holds them), bit-identical to the face-normal + gather split that workers share.
		plNormalsScatterJob scatter = { plMakeConstSpan( inst->positions, a->vertex_count, 12 ), a->faces, a->face_count,
										plMakeSpan( inst->normals, a->vertex_count, 12 ), inst->face_normals,
										a->face_count, &inst->ctx->kernels };
		plNormalsScatterJob_Run( &scatter );
		PLEAT_STEP_PHASE( PLEAT_PHASE_GATHER );
		return;
	}
	plRunTask( runner, plFaceNormalsTask, a->face_count, 512, &task );
	plRunTask( runner, plNormalsTask, a->vertex_count, 256, &task );
}

// ---- create / destroy ----

static size_t plAlign64( size_t v )
{
	return ( v + 63u ) & ~(size_t)63u;
}

// The instance table's destroy callback (plDestroyObjectFn), also what plDestroyInstance frees with.
static void plInstanceData_Destroy( plContextData* ctx, void* object )
{
	plInstanceData* inst = (plInstanceData*)object;
	if ( inst->gl != NULL )
	{
		plGlDeformer_Destroy( inst->gl );
	}
	if ( inst->ort_lp != NULL )
	{
		plOrtMlp_Destroy( inst->ort_lp );
	}
	if ( inst->ort_dec != NULL )
	{
		plOrtMlp_Destroy( inst->ort_dec );
	}
	if ( inst->asset != NULL && inst->asset->instance_count > 0 )
	{
		inst->asset->instance_count -= 1;
	}
	plFree( &ctx->allocator, inst->block, inst->block_size );
	plFree( &ctx->allocator, inst, sizeof( plInstanceData ) );
}

static plResult plCreateBackends( plInstanceData* inst, const plInstanceDef* def )
{
	plAssetData* a = inst->asset;
	plContextData* ctx = inst->ctx;
	if ( def->mlp_backend == PLEAT_MLP_BACKEND_ONNXRUNTIME )
	{
		if ( a->onnx_lp == NULL || a->onnx_dec == NULL )
		{
			plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_BACKEND_UNAVAILABLE, "asset has no OXLP/OXDC sections" );
			return PLEAT_RESULT_BACKEND_UNAVAILABLE;
		}
		plResult r = plOrtMlp_Create( def->onnxruntime_library, a->onnx_lp, a->onnx_lp_size, a->input_count,
									  a->latent_count, &ctx->allocator, &inst->ort_lp );
		if ( r == PLEAT_RESULT_OK )
		{
			r = plOrtMlp_Create( def->onnxruntime_library, a->onnx_dec, a->onnx_dec_size, a->latent_count,
								 a->blend_count, &ctx->allocator, &inst->ort_dec );
		}
		if ( r != PLEAT_RESULT_OK )
		{
			char why[400];
			if ( r == PLEAT_RESULT_BACKEND_UNAVAILABLE &&
				 plOrtMlp_DescribeUnavailable( def->onnxruntime_library, why, sizeof( why ) ) )
			{
				plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_BACKEND_UNAVAILABLE, "%s: %s", plResultString( r ), why );
			}
			else
			{
				plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_BACKEND_UNAVAILABLE, "%s", plResultString( r ) );
			}
			return r;
		}
	}
	if ( def->gpu_mode != PLEAT_GPU_NONE )
	{
		plGlDeformerDesc desc;
		memset( &desc, 0, sizeof( desc ) );
		desc.mode = def->gpu_mode == PLEAT_GPU_HOST_CONTEXT ? PLEAT_GL_DEFORMER_HOST_CONTEXT : PLEAT_GL_DEFORMER_HEADLESS;
		desc.vertex_count = a->vertex_count;
		desc.face_count = a->face_count;
		desc.blend_count = a->blend_count;
		desc.influence_count = a->influence_count;
		desc.joint_count = a->joint_count;
		desc.shaped_template = inst->shaped_template;
		desc.blend_shapes = a->blend_shapes;
		desc.blend_shapes_fp16 = a->blend_shapes_fp16;
		desc.skin_indices = a->skin_indices;
		desc.skin_weights = a->skin_weights;
		desc.faces = a->faces;
		desc.adjacency_offsets = a->adjacency_offsets;
		desc.adjacency_faces = a->adjacency_faces;
		desc.host_position_buffer = def->gpu_mode == PLEAT_GPU_HOST_CONTEXT ? def->host_position_buffer : 0;
		desc.host_normal_buffer = def->gpu_mode == PLEAT_GPU_HOST_CONTEXT ? def->host_normal_buffer : 0;
		// Headless: the SDK picks the platform and device itself, so it says which it got (a GPU machine silently
		// running on a software rasteriser is the failure this makes visible).
		char report[448];
		report[0] = '\0';
		desc.report = report;
		desc.report_size = sizeof( report );
		plResult r = plGlDeformer_Create( &desc, &ctx->allocator, &inst->gl );
		if ( r != PLEAT_RESULT_OK )
		{
			inst->gl = NULL;
			plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_GL_UNAVAILABLE, "%s%s%s", plResultString( r ),
				   report[0] != '\0' ? ": " : "", report );
			return r;
		}
		if ( def->gpu_mode == PLEAT_GPU_HEADLESS )
		{
			plLog( ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_GL_HEADLESS_CONTEXT, "%s", report );
		}
	}
	return PLEAT_RESULT_OK;
}

plResult plCreateInstance( plContext context, const plInstanceDef* def, plInstance* out_instance )
{
	if ( out_instance != NULL )
	{
		memset( out_instance, 0, sizeof( *out_instance ) );
	}
	if ( def == NULL || out_instance == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plContextData* ctx = plGetContext( context );
	if ( ctx == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	// Every rejection below names the def field (and entry) in the log: the result code alone cannot say which of a
	// dozen fields an integrator got wrong.
	if ( def->internal_cookie != PLEAT_DEF_COOKIE )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF,
			   "internal_cookie: the def was not made by plDefaultInstanceDef()" );
		return PLEAT_RESULT_INVALID_DEF;
	}
	plAssetData* a = plGetAssetData( def->asset );
	if ( a == NULL || plGetContext( def->asset.context ) != ctx )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF,
			   "asset: null, destroyed or from another context" );
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	if ( def->mlp_backend != PLEAT_MLP_BACKEND_PLEAT && def->mlp_backend != PLEAT_MLP_BACKEND_ONNXRUNTIME )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF, "mlp_backend %d is not a plMlpBackend",
			   (int)def->mlp_backend );
		return PLEAT_RESULT_INVALID_DEF;
	}
	if ( def->gpu_mode != PLEAT_GPU_NONE && def->gpu_mode != PLEAT_GPU_HOST_CONTEXT && def->gpu_mode != PLEAT_GPU_HEADLESS )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF, "gpu_mode %d is not a plGpuMode",
			   (int)def->gpu_mode );
		return PLEAT_RESULT_INVALID_DEF;
	}
	if ( def->beta_count > a->beta_count || ( def->beta == NULL && def->beta_count != 0 ) )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF,
			   "beta_count %u: the asset has %u shape components%s", def->beta_count, a->beta_count,
			   def->beta == NULL ? " and beta is NULL" : "" );
		return PLEAT_RESULT_INVALID_DEF;
	}
	if ( !( isfinite( def->network_rate_hz ) && def->network_rate_hz >= 0.0f ) )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF, "network_rate_hz %g: must be finite and >= 0",
			   (double)def->network_rate_hz );
		return PLEAT_RESULT_INVALID_DEF;
	}
	uint32_t engine_joints = def->engine_joint_count != 0 ? def->engine_joint_count : a->joint_count;
	if ( def->joint_map != NULL )
	{
		if ( def->joint_map_count != a->joint_count )
		{
			plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF,
				   "joint_map_count %u: must equal the asset's joint count %u (one entry per asset joint)",
				   def->joint_map_count, a->joint_count );
			return PLEAT_RESULT_JOINT_COUNT_MISMATCH;
		}
		for ( uint32_t j = 0; j < a->joint_count; ++j )
		{
			if ( def->joint_map[j] < -1 || def->joint_map[j] >= (int64_t)engine_joints )
			{
				plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF,
					   "joint_map[%u] (asset joint '%s') = %d: outside -1..%u (engine_joint_count %u)", j,
					   a->joint_names + (size_t)j * PLEAT_JOINT_NAME_SIZE, (int)def->joint_map[j], engine_joints - 1u,
					   engine_joints );
				return PLEAT_RESULT_JOINT_COUNT_MISMATCH;
			}
		}
	}
	else if ( engine_joints != a->joint_count )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF,
			   "engine_joint_count %u without a joint_map: must be 0 or the asset's joint count %u",
			   def->engine_joint_count, a->joint_count );
		return PLEAT_RESULT_JOINT_COUNT_MISMATCH;
	}
	for ( uint32_t b = 0; b < def->beta_count; ++b )
	{
		if ( !isfinite( def->beta[b] ) )
		{
			plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF, "beta[%u] = %g is not finite", b,
				   (double)def->beta[b] );
			return PLEAT_RESULT_NON_FINITE_INPUT;
		}
	}
	if ( def->material != NULL && !plAllFiniteFloats( def->material, 4 ) )
	{
		static const char* const material_names[4] = { "areal density m", "mu", "lambda", "bending k" };
		for ( uint32_t i = 0; i < 4; ++i )
		{
			if ( !isfinite( def->material[i] ) )
			{
				plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF, "material[%u] (%s) = %g is not finite",
					   i, material_names[i], (double)def->material[i] );
				break;
			}
		}
		return PLEAT_RESULT_NON_FINITE_INPUT;
	}

	plInstanceData* inst = (plInstanceData*)plAllocZeroed( &ctx->allocator, sizeof( plInstanceData ), 64 );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	inst->ctx = ctx;
	inst->asset = a;
	inst->asset_handle = def->asset;
	inst->user_data = def->user_data;
	inst->network_interval_s = def->network_rate_hz > 0.0f ? 1.0 / def->network_rate_hz : 0.0;
	inst->engine_joint_count = engine_joints;
	for ( uint32_t j = 0; j < a->joint_count; ++j )
	{
		inst->joint_map[j] = def->joint_map != NULL ? def->joint_map[j] : (int32_t)j;
	}
	uint32_t widest = 0;
	for ( uint32_t i = 0; i + 1 < a->lp_layer_count; ++i )
	{
		widest = a->lp[i].out_count > widest ? a->lp[i].out_count : widest;
	}
	for ( uint32_t i = 0; i + 1 < a->dec_layer_count; ++i )
	{
		widest = a->dec[i].out_count > widest ? a->dec[i].out_count : widest;
	}
	inst->mlp_scratch_count = 2 * ( widest > 0 ? widest : 1 );
	size_t n3 = (size_t)a->vertex_count * 3 * sizeof( float );
	size_t sizes[13] = { n3,
						 a->latent_count * sizeof( float ),
						 a->latent_count * sizeof( float ),
						 a->input_count * sizeof( float ),
						 a->latent_count * sizeof( float ),
						 a->blend_count * sizeof( float ),
						 a->blend_count * sizeof( float ),
						 inst->mlp_scratch_count * sizeof( float ),
						 n3,
						 n3,
						 n3,
						 (size_t)a->face_count * 4 * sizeof( float ),
						 def->gpu_mode != PLEAT_GPU_NONE ? n3 : 0 };
	size_t total = 0;
	for ( int i = 0; i < 13; ++i )
	{
		total += plAlign64( sizes[i] );
	}
	inst->block = plAllocZeroed( &ctx->allocator, total, 64 );
	if ( inst->block == NULL )
	{
		plFree( &ctx->allocator, inst, sizeof( plInstanceData ) );
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	inst->block_size = total;
	float** targets[13] = { &inst->shaped_template, &inst->latent,        &inst->next_latent, &inst->x,
							&inst->y,               &inst->blend_weights, &inst->next_weights, &inst->mlp_scratch,
							&inst->deformed,        &inst->positions,     &inst->normals,     &inst->face_normals,
							&inst->gl_normals };
	uint8_t* cursor = (uint8_t*)inst->block;
	for ( int i = 0; i < 13; ++i )
	{
		*targets[i] = sizes[i] != 0 ? (float*)cursor : NULL;
		cursor += plAlign64( sizes[i] );
	}

	int clamped = plClampBeta( a, def->beta, def->beta_count, inst->beta );
	clamped |= plClampMaterial( a, def->material, inst->material, inst->material_normalized );
	plApplyShape( inst );
	// Before the first step: the rest pose, i.e. the shaped template with identity skinning matrices.
	for ( uint32_t j = 0; j < a->joint_count; ++j )
	{
		float* m = inst->skin_matrices + j * 12;
		m[0] = m[5] = m[10] = 1.0f;
	}
	memcpy( inst->positions, inst->shaped_template, n3 );
	memcpy( inst->deformed, inst->shaped_template, n3 );
	plDeformTask task = { inst, inst->blend_weights, inst->skin_matrices, 0 };
	plFaceNormalsTask( 0, a->face_count, 0, &task );
	plNormalsTask( 0, a->vertex_count, 0, &task );

	plResult r = plCreateBackends( inst, def );
	uint32_t slot = UINT32_MAX;
	if ( r == PLEAT_RESULT_OK )
	{
		slot = plSlotTable_Insert( ctx, &ctx->instances, inst, plInstanceData_Destroy );
		if ( slot == UINT32_MAX )
		{
			r = PLEAT_RESULT_OUT_OF_MEMORY;
		}
	}
	a->instance_count += 1;
	if ( r != PLEAT_RESULT_OK )
	{
		plInstanceData_Destroy( ctx, inst );
		return r;
	}
	out_instance->index1 = slot + 1;
	out_instance->generation = ctx->instances.slots[slot].generation;
	out_instance->context = ctx->handle;
	plLog( ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_INSTANCE_CREATED, "asset '%s'", a->name );
	return clamped ? PLEAT_RESULT_CLAMPED : PLEAT_RESULT_OK;
}

plResult plDestroyInstance( plInstance handle )
{
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	plContextData* ctx = inst->ctx;
	plInstanceData_Destroy( ctx, inst );
	plSlotTable_Remove( &ctx->instances, handle.index1 );
	return PLEAT_RESULT_OK;
}

int plInstance_IsValid( plInstance handle )
{
	return plGetInstanceData( handle ) != NULL;
}

// ---- step ----

static int plValidQuatLength( const double q[4], double* out_length )
{
	double length = sqrt( q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] );
	*out_length = length;
	return fabs( length - 1.0 ) <= 1e-3;
}

// Evaluates one step from the given history (NULL = first frame) into next_latent / next_weights / positions /
// normals / next_skin_matrices. Returns 0 if a non-finite value appeared.
static int plEvaluate( plInstanceData* inst, const plPoseFrame* frame_t, const plPoseFrame* frame_tm1,
					   const float* latent, plResult* backend_error )
{
	plAssetData* a = inst->asset;
	plContextData* ctx = inst->ctx;
	const plTaskRunner* runner = &ctx->runner;
	plPoseFrame* now = &inst->next_frame;
	plInputAssemblyJob assembly;
	memset( &assembly, 0, sizeof( assembly ) );
	assembly.frames[0] = now;
	assembly.frames[1] = frame_t != NULL ? frame_t : now;
	assembly.frames[2] = frame_tm1 != NULL ? frame_tm1 : now;
	assembly.latent = latent;
	assembly.latent_count = a->latent_count;
	assembly.input_joints = a->input_joints;
	assembly.input_joint_count = a->input_joint_count;
	assembly.beta = inst->beta;
	assembly.beta_count = a->beta_count;
	assembly.material_normalized = inst->material_normalized;
	assembly.output = plMakeSpan( inst->x, a->input_count, 4 );
	plInputAssemblyJob_Run( &assembly );
	for ( uint32_t i = 0; i < a->input_count; ++i )
	{
		inst->x[i] = ( inst->x[i] - a->x_mean[i] ) / a->x_std[i];
	}
	PLEAT_STEP_PHASE( PLEAT_PHASE_INPUT );
	// f_LP
	if ( inst->ort_lp != NULL )
	{
		*backend_error = plOrtMlp_Run( inst->ort_lp, inst->x, inst->y );
		if ( *backend_error != PLEAT_RESULT_OK )
		{
			return 1;
		}
	}
	else
	{
		plMlpJob lp = { a->lp, a->lp_layer_count, a->lp_activation, plMakeConstSpan( inst->x, a->input_count, 4 ),
						plMakeSpan( inst->y, a->latent_count, 4 ),
						plMakeSpan( inst->mlp_scratch, inst->mlp_scratch_count, 4 ), &ctx->kernels, runner };
		plMlpJob_Run( &lp );
	}
	PLEAT_STEP_PHASE( PLEAT_PHASE_LP );
	if ( !plAllFiniteFloats( inst->y, a->latent_count ) )
	{
		return 0;
	}
	PLEAT_STEP_PHASE( PLEAT_PHASE_GUARDS );
	// The latent guard.
	for ( uint32_t i = 0; i < a->latent_count; ++i )
	{
		float z = inst->y[i] * a->z_std[i] + a->z_mean[i];
		z = z < a->z_min[i] ? a->z_min[i] : z;
		z = z > a->z_max[i] ? a->z_max[i] : z;
		inst->next_latent[i] = z;
	}
	// f_dec
	if ( inst->ort_dec != NULL )
	{
		*backend_error = plOrtMlp_Run( inst->ort_dec, inst->next_latent, inst->next_weights );
		if ( *backend_error != PLEAT_RESULT_OK )
		{
			return 1;
		}
	}
	else
	{
		plMlpJob dec = { a->dec, a->dec_layer_count, a->dec_activation,
						 plMakeConstSpan( inst->next_latent, a->latent_count, 4 ),
						 plMakeSpan( inst->next_weights, a->blend_count, 4 ),
						 plMakeSpan( inst->mlp_scratch, inst->mlp_scratch_count, 4 ), &ctx->kernels, runner };
		plMlpJob_Run( &dec );
	}
	PLEAT_STEP_PHASE( PLEAT_PHASE_DEC );
	int finite = plAllFiniteFloats( inst->next_weights, a->blend_count ) &&
				 plAllFiniteFloats( inst->next_skin_matrices, (size_t)a->joint_count * 12 );
	PLEAT_STEP_PHASE( PLEAT_PHASE_GUARDS );
	return finite;
}

// reuse_deformed: skin the committed T_def again (CPU path, a step between network updates) instead of blending.
static int plDeform( plInstanceData* inst, int read_back, plResult* gl_error, int reuse_deformed )
{
	const plAssetData* a = inst->asset;
	if ( inst->gl != NULL )
	{
		// Read back into scratch: plInstance_Step copies it to positions/normals only once nothing can fail any more,
		// so a GL error leaves the instance's buffers as they were.
		*gl_error = plGlDeformer_Run( inst->gl, inst->next_weights, inst->next_skin_matrices,
									  read_back ? inst->deformed : NULL, read_back ? inst->gl_normals : NULL );
		return 1;
	}
	int blend = !( reuse_deformed && inst->deformed_is_committed );
	if ( blend )
	{
		inst->deformed_is_committed = 0; // until this step commits
	}
	plDeformCpu( inst, inst->next_weights, inst->next_skin_matrices, blend );
	size_t n3 = (size_t)a->vertex_count * 3;
	int finite = plAllFiniteFloats( inst->positions, n3 ) && plAllFiniteFloats( inst->normals, n3 );
	PLEAT_STEP_PHASE( PLEAT_PHASE_GUARDS );
	return finite;
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

plResult plInstance_Step( plInstance handle, const plFrameInput* input, const plStepOutput* output )
{
	PLEAT_STEP_PHASE_START();
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	if ( input == NULL || input->joint_rotations == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plAssetData* a = inst->asset;
	plContextData* ctx = inst->ctx;
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
	double quats[PLEAT_MAX_JOINTS][4];
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
	double root_q[4] = { input->root_rotation.x, input->root_rotation.y, input->root_rotation.z,
						 input->root_rotation.w };
	double root_t[3] = { input->root_translation.x, input->root_translation.y, input->root_translation.z };
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
	// The networks run on this step unless a network rate is set and less than its interval has gathered since their
	// last update; when they run, their dt is all the time since that update (docs/inputs.md, "Network update rate").
	int run_network = inst->network_interval_s <= 0.0 || !inst->history_valid ||
					  inst->network_pending_s + input->dt_s >= inst->network_interval_s * ( 1.0 - 1e-6 );
	double dt = run_network ? inst->network_pending_s + input->dt_s : input->dt_s;
	int clamped = 0;
	if ( run_network && dt < a->dt_min_s )
	{
		dt = a->dt_min_s;
		clamped = 1;
	}
	else if ( run_network && dt > a->dt_max_s )
	{
		dt = a->dt_max_s;
		clamped = 1;
	}

	PLEAT_STEP_PHASE( PLEAT_PHASE_VALIDATE );
	// Nothing has changed so far. Forward kinematics for frame t+1 into the scratch frame.
	plPoseFrame* now = &inst->next_frame;
	for ( uint32_t j = 0; j < a->joint_count; ++j )
	{
		plQuatToMatrix( quats[j], now->local_rotations[j] );
	}
	double root_rotation[9];
	plQuatToMatrix( root_q, root_rotation );
	plForwardKinematicsJob fk = { a->parents,    a->joint_count,
								  inst->rest_joints, root_t,
								  root_rotation, inst->history_valid ? inst->history[0].yaw : 0.0,
								  dt,            now,
								  inst->next_skin_matrices };
	plForwardKinematicsJob_Run( &fk );
	PLEAT_STEP_PHASE( PLEAT_PHASE_FK );

	int read_back = inst->gl == NULL || ( output != NULL && ( output->positions != NULL || output->normals != NULL ) );
	plResult backend_error = PLEAT_RESULT_OK;
	plResult gl_error = PLEAT_RESULT_OK;
	int reset = 0;
	int ok = 0;
	if ( !run_network )
	{
		// Between network updates: the held blend weights' deformation, skinned with the new pose (the latent is not
		// committed on such a step, so next_latent is not needed).
		memcpy( inst->next_weights, inst->blend_weights, a->blend_count * sizeof( float ) );
		ok = plDeform( inst, read_back, &gl_error, 1 );
	}
	else
	{
		ok = plEvaluate( inst, inst->history_valid ? &inst->history[0] : NULL,
						 inst->history_valid ? &inst->history[1] : NULL, inst->latent, &backend_error );
		if ( backend_error != PLEAT_RESULT_OK )
		{
			return backend_error;
		}
		if ( ok )
		{
			ok = plDeform( inst, read_back, &gl_error, 0 );
		}
	}
	if ( !ok && gl_error == PLEAT_RESULT_OK )
	{
		// Non-finite inside the step: recompute as a first frame with a zero latent. The instance's own latent and
		// history stay untouched until the commit below (a GL error after this point must still change nothing);
		// next_latent is the zero input latent (input assembly reads it before f_LP overwrites it).
		reset = 1;
		run_network = 1;
		memset( inst->next_latent, 0, a->latent_count * sizeof( float ) );
		fk.previous_yaw = 0.0;
		plForwardKinematicsJob_Run( &fk );
		ok = plEvaluate( inst, NULL, NULL, inst->next_latent, &backend_error );
		if ( ok && backend_error == PLEAT_RESULT_OK )
		{
			ok = plDeform( inst, read_back, &gl_error, 0 );
		}
		if ( !ok || backend_error != PLEAT_RESULT_OK )
		{
			// Still non-finite from the reset state: dress the body without the learned deformation.
			memset( inst->next_latent, 0, a->latent_count * sizeof( float ) );
			memset( inst->next_weights, 0, a->blend_count * sizeof( float ) );
			plDeform( inst, read_back, &gl_error, 0 );
		}
		plLog( ctx, PLEAT_LOG_LEVEL_WARNING, PLEAT_LOG_INSTANCE_NUMERIC_RESET, NULL );
	}
	if ( gl_error != PLEAT_RESULT_OK )
	{
		return gl_error;
	}

	// Commit. After a network update: t−1 ← t (or t+1 on a first frame or after a reset), t ← t+1, Z_t ← Z_t+1.
	// Between updates only the pose-dependent outputs change, and the time since the update grows.
	if ( run_network )
	{
		inst->history[1] = inst->history_valid && !reset ? inst->history[0] : *now;
		inst->history[0] = *now;
		inst->history_valid = 1;
		inst->network_pending_s = 0.0;
		memcpy( inst->latent, inst->next_latent, a->latent_count * sizeof( float ) );
		memcpy( inst->blend_weights, inst->next_weights, a->blend_count * sizeof( float ) );
	}
	else
	{
		inst->network_pending_s += input->dt_s;
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
	if ( reset )
	{
		return PLEAT_RESULT_NUMERIC_RESET;
	}
	if ( clamped )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_INSTANCE_INPUT_CLAMPED, "dt_s %g", input->dt_s );
		return PLEAT_RESULT_CLAMPED;
	}
	return PLEAT_RESULT_OK;
}

plResult plInstance_Reset( plInstance handle )
{
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	inst->history_valid = 0;
	inst->network_pending_s = 0.0;
	memset( inst->latent, 0, inst->asset->latent_count * sizeof( float ) );
	return PLEAT_RESULT_OK;
}

plResult plInstance_SetNetworkRate( plInstance handle, float network_rate_hz )
{
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	if ( !( isfinite( network_rate_hz ) && network_rate_hz >= 0.0f ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	inst->network_interval_s = network_rate_hz > 0.0f ? 1.0 / network_rate_hz : 0.0;
	return PLEAT_RESULT_OK;
}

plResult plInstance_SetShape( plInstance handle, const float* beta, uint32_t beta_count )
{
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	if ( ( beta == NULL && beta_count != 0 ) || beta_count > inst->asset->beta_count )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( beta != NULL && !plAllFiniteFloats( beta, beta_count ) )
	{
		return PLEAT_RESULT_NON_FINITE_INPUT;
	}
	const plAssetData* a = inst->asset;
	float clamped_beta[PLEAT_MAX_BETAS];
	int clamped = plClampBeta( a, beta, beta_count, clamped_beta );
	if ( inst->gl != NULL )
	{
		// The new template goes to the GPU before anything on the CPU changes, so a GL error leaves β, J(β) and the
		// template as they were (an error changes nothing). It is built in `deformed`, which on the GPU path only
		// receives read-backs and holds nothing between calls. The GPU copy is unchanged too after a failure: GL
		// ignores a command that raises an error, and the upload is one BufferSubData.
		plShapeTemplate( a, clamped_beta, inst->deformed );
		plResult r = plGlDeformer_SetShapedTemplate( inst->gl, inst->deformed );
		if ( r != PLEAT_RESULT_OK )
		{
			return r;
		}
		memcpy( inst->beta, clamped_beta, a->beta_count * sizeof( float ) );
		memcpy( inst->shaped_template, inst->deformed, (size_t)a->vertex_count * 3 * sizeof( float ) );
		plShapeJoints( a, inst->beta, inst->rest_joints );
	}
	else
	{
		memcpy( inst->beta, clamped_beta, a->beta_count * sizeof( float ) );
		plApplyShape( inst );
	}
	inst->deformed_is_committed = 0; // T_def changes with β: the next step blends again
	if ( clamped )
	{
		plLog( inst->ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_INSTANCE_INPUT_CLAMPED, "beta" );
	}
	return clamped ? PLEAT_RESULT_CLAMPED : PLEAT_RESULT_OK;
}

plResult plInstance_SetMaterial( plInstance handle, const float material[4] )
{
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	if ( material == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( !plAllFiniteFloats( material, 4 ) )
	{
		return PLEAT_RESULT_NON_FINITE_INPUT;
	}
	int clamped = plClampMaterial( inst->asset, material, inst->material, inst->material_normalized );
	if ( clamped )
	{
		plLog( inst->ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_INSTANCE_INPUT_CLAMPED, "material" );
	}
	return clamped ? PLEAT_RESULT_CLAMPED : PLEAT_RESULT_OK;
}

plResult plInstance_GetPositions( plInstance handle, const float** out_positions, uint32_t* out_count )
{
	if ( out_positions == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	*out_positions = NULL;
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	*out_positions = inst->positions;
	if ( out_count != NULL )
	{
		*out_count = inst->asset->vertex_count;
	}
	return PLEAT_RESULT_OK;
}

plResult plInstance_GetNormals( plInstance handle, const float** out_normals, uint32_t* out_count )
{
	if ( out_normals == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	*out_normals = NULL;
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	*out_normals = inst->normals;
	if ( out_count != NULL )
	{
		*out_count = inst->asset->vertex_count;
	}
	return PLEAT_RESULT_OK;
}

// The getters that copy one of the instance's float arrays out: the caller's capacity must hold all of it.
static plResult plCopyFloatsOut( const float* source, size_t count, float* out, size_t capacity )
{
	if ( out == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( capacity < count )
	{
		return PLEAT_RESULT_BUFFER_TOO_SMALL;
	}
	memcpy( out, source, count * sizeof( float ) );
	return PLEAT_RESULT_OK;
}

plResult plInstance_GetSkinMatrices( plInstance handle, float* out, uint32_t joint_count )
{
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	// counts are of 3x4 matrices
	return plCopyFloatsOut( inst->skin_matrices, (size_t)inst->asset->joint_count * 12, out, (size_t)joint_count * 12 );
}

plResult plInstance_GetLatent( plInstance handle, float* out, uint32_t latent_count )
{
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	return plCopyFloatsOut( inst->latent, inst->asset->latent_count, out, latent_count );
}

plResult plInstance_GetBlendWeights( plInstance handle, float* out, uint32_t blend_count )
{
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	return plCopyFloatsOut( inst->blend_weights, inst->asset->blend_count, out, blend_count );
}

plResult plInstance_GetShape( plInstance handle, float* out_beta, uint32_t beta_count, float out_material[4] )
{
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	if ( ( out_beta == NULL && beta_count != 0 ) || beta_count > PLEAT_MAX_BETAS )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	for ( uint32_t b = 0; b < beta_count; ++b )
	{
		out_beta[b] = b < inst->asset->beta_count ? inst->beta[b] : 0.0f;
	}
	if ( out_material != NULL )
	{
		memcpy( out_material, inst->material, sizeof( inst->material ) );
	}
	return PLEAT_RESULT_OK;
}

plResult plInstance_GetAsset( plInstance handle, plAsset* out_asset )
{
	if ( out_asset == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		memset( out_asset, 0, sizeof( *out_asset ) );
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	*out_asset = inst->asset_handle;
	return PLEAT_RESULT_OK;
}

void* plInstance_GetUserData( plInstance handle )
{
	plInstanceData* inst = plGetInstanceData( handle );
	return inst != NULL ? inst->user_data : NULL;
}

plResult plInstance_GetRestPose( plInstance handle, plRestJoint* out_joints, uint32_t joint_capacity )
{
	if ( out_joints == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	if ( joint_capacity < inst->asset->joint_count )
	{
		return PLEAT_RESULT_BUFFER_TOO_SMALL;
	}
	// rest_joints is the J(β) forward kinematics uses (plApplyShape), so a retarget sees exactly those joints.
	plFillRestPose( inst->asset->parents, inst->rest_joints, inst->asset->joint_count, out_joints );
	return PLEAT_RESULT_OK;
}
