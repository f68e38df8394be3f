// The instance's lifetime (create with its buffers and backends, destroy), its shape, material and other settings.
// The step is instance_step.c, the CPU deformation instance_deform.c, the getters instance_query.c (instance.h lists
// them).
#include "instance.h"
#include "asset/skeleton.h"
#include "core/step_phases.h"

#include <math.h>
#include <string.h>

plInstanceData* plGetInstanceData( plInstance handle )
{
	plContextData* ctx = plGetContext( handle.context ); // the context generation too: its slot may have a new context
	return ctx != NULL ? (plInstanceData*)plSlotTable_Get( &ctx->instances, handle.index1, handle.generation ) : NULL;
}

// In host-context mode every GL call needs the engine's context current on the calling thread; the GL path answers
// GL_UNAVAILABLE when none is (it would otherwise do nothing and report success). The code alone does not say that
// the fix is on the engine's side, so the log does.
plResult plLogIfNoGlContext( const plInstanceData* inst, plResult r, const char* function )
{
	if ( r == PLEAT_RESULT_GL_UNAVAILABLE )
	{
		plLog( inst->ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_GL_UNAVAILABLE,
			   "%s: no GL context is current on the calling thread (host-context mode: make the engine's context "
			   "current first); nothing changed",
			   function );
	}
	return r;
}

// A handle that names no live instance is almost always a use after plDestroyInstance, and INVALID_HANDLE alone does
// not say which call or which handle it was; the log does, where the handle's context is still alive to receive it.
void plLogStaleInstance( const plContextData* ctx, plInstance handle, const char* function, const char* detail )
{
	plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_STALE_HANDLE, "%s: handle (slot %u, generation %u) %s",
		   function, handle.index1, handle.generation, detail );
}

plInstanceData* plLookupInstance( plInstance handle, const char* function )
{
	plInstanceData* inst = plGetInstanceData( handle );
	if ( inst == NULL )
	{
		plLogStaleInstance( plGetContext( handle.context ), handle, function,
							"is stale: its instance was destroyed" );
	}
	return inst;
}

int plInstance_IsValid( plInstance handle )
{
	return plGetInstanceData( handle ) != NULL;
}

plInstanceDef plDefaultInstanceDef( void )
{
	plInstanceDef def = { .mlp_backend = PLEAT_MLP_BACKEND_PLEAT,
						  .gpu_mode = PLEAT_GPU_MODE_NONE,
						  .body_contact = 1,
						  .body_contact_offset_m = PLEAT_BODY_CONTACT_DEFAULT_OFFSET_M,
						  .internal_cookie = PLEAT_DEF_COOKIE };
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

// The shaped template T + G_S(β) of beta into out ([N][3]), J(β) into out_joints ([J][3]) and, for an asset with body
// contact, the body points of β into out_anchors ([P][3]; the same shape blend with the body's directions).
static plResult plApplyShape( const plAssetData* a, const float* beta, float* out, double* out_joints,
							  float* out_anchors )
{
	plShapeBlendJob template_job = { plMakeConstSpan( a->template_positions, a->vertex_count, 12 ), a->shape_blend,
									 plMakeConstSpan( beta, a->beta_count, 4 ), plMakeSpan( out, a->vertex_count, 12 ) };
	plShapedJointsJob joints_job = { a->joint_template, a->joint_shapedirs, a->joint_count,
									 plMakeConstSpan( beta, a->beta_count, 4 ), out_joints };
	if ( plShapeBlendJob_Run( &template_job ) != PLEAT_RESULT_OK || plShapedJointsJob_Run( &joints_job ) != PLEAT_RESULT_OK )
	{
		return PLEAT_RESULT_INTERNAL_ERROR;
	}
	if ( a->body_anchors != NULL )
	{
		plShapeBlendJob anchor_job = { plMakeConstSpan( a->body_anchors, a->body_point_count, 12 ),
									   a->body_anchor_shape, plMakeConstSpan( beta, a->beta_count, 4 ),
									   plMakeSpan( out_anchors, a->body_point_count, 12 ) };
		if ( out_anchors == NULL || plShapeBlendJob_Run( &anchor_job ) != PLEAT_RESULT_OK )
		{
			return PLEAT_RESULT_INTERNAL_ERROR;
		}
	}
	return PLEAT_RESULT_OK;
}

// The contact an instance runs: none, the full one, or the fast one (asked for, or the only one a 1.1 asset has,
// where the two are the same map) where the asset allows it (plAssetData.body_contact_fast_ready).
static void plSetContactMode( plInstanceData* inst, int mode )
{
	const plAssetData* a = inst->asset;
	int asset_1_1 = a->body_anchor_candidates == NULL && a->body_anchor_ring == NULL;
	inst->body_contact = mode != PLEAT_BODY_CONTACT_OFF && a->body_anchors != NULL;
	inst->body_contact_fast = inst->body_contact && a->body_contact_fast_ready &&
							  ( mode == PLEAT_BODY_CONTACT_FAST || asset_1_1 );
}

static int plBodyContactOffsetValid( float offset_m )
{
	return isfinite( offset_m ) && offset_m >= 0.0f && offset_m <= PLEAT_BODY_CONTACT_MAX_OFFSET_M;
}

// ---- create / destroy ----

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
	if ( def->gpu_mode != PLEAT_GPU_MODE_NONE )
	{
		plGlDeformerDesc desc;
		memset( &desc, 0, sizeof( desc ) );
		desc.mode = def->gpu_mode == PLEAT_GPU_MODE_HOST_CONTEXT ? PLEAT_GL_DEFORMER_HOST_CONTEXT
																: PLEAT_GL_DEFORMER_HEADLESS;
		desc.vertex_count = a->vertex_count;
		desc.face_count = a->face_count;
		desc.blend_count = a->blend_count;
		desc.influence_count = a->influence_count;
		desc.joint_count = a->joint_count;
		desc.shaped_template = inst->shaped_template;
		desc.blend_shapes = a->blend_shapes;
		desc.skin_indices = a->skin_indices;
		desc.skin_weights = a->skin_weights;
		desc.faces = a->faces;
		desc.adjacency_offsets = a->adjacency_offsets;
		desc.adjacency_faces = a->adjacency_faces;
		if ( a->body_anchors != NULL )
		{
			desc.body_anchors = inst->shaped_anchors;
			desc.body_anchor_normals = a->body_anchor_normals;
			desc.body_anchor_skin_indices = a->body_anchor_skin_indices;
			desc.body_anchor_skin_weights = a->body_anchor_skin_weights;
			desc.body_anchor_influence_count = a->body_anchor_influence_count;
			desc.body_point_count = a->body_point_count;
			desc.body_anchor_candidates = a->body_anchor_candidates;
			desc.body_anchor_candidate_count = a->body_anchor_candidate_count;
			desc.body_anchor_ring = a->body_anchor_ring;
			desc.body_anchor_ring_count = a->body_anchor_ring_count;
		}
		plGlNetworksDesc networks = { a->lp,     a->lp_layer_count, a->lp_activation, a->dec,  a->dec_layer_count,
									  a->dec_activation, a->z_mean,  a->z_std,  a->z_min, a->z_max };
		desc.networks = def->mlp_backend == PLEAT_MLP_BACKEND_GPU ? &networks : NULL;
		// plCreateInstance checked that a gpu_share is a live GPU instance of this asset, mode and backend.
		plInstanceData* share = def->gpu_share.index1 != 0 ? plGetInstanceData( def->gpu_share ) : NULL;
		desc.share = share != NULL ? share->gl : NULL;
		desc.host_position_buffer = def->gpu_mode == PLEAT_GPU_MODE_HOST_CONTEXT ? def->host_position_buffer : 0;
		desc.host_normal_buffer = def->gpu_mode == PLEAT_GPU_MODE_HOST_CONTEXT ? def->host_normal_buffer : 0;
		// Headless: the SDK picks the platform and device itself, so it says which it got (a GPU machine silently
		// running on a software rasteriser is the failure this makes visible).
		char report[448];
		report[0] = '\0';
		desc.report = report;
		desc.report_size = sizeof( report );
		plResult r = plGlDeformer_Create( &desc, &ctx->allocator, &inst->gl );
		if ( r == PLEAT_RESULT_BACKEND_UNAVAILABLE )
		{
			inst->gl = NULL;
			plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_BACKEND_UNAVAILABLE,
				   "the GPU backend runs fp32 and fp16 networks; this asset's are int8 (the CPU backend runs them)" );
			return r;
		}
		if ( r != PLEAT_RESULT_OK )
		{
			inst->gl = NULL;
			plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_GL_UNAVAILABLE, "%s%s%s", plResultString( r ),
				   report[0] != '\0' ? ": " : "", report );
			return r;
		}
		if ( def->gpu_mode == PLEAT_GPU_MODE_HEADLESS )
		{
			plLog( ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_GL_HEADLESS_CONTEXT, "%s", report );
		}
		r = plGlDeformer_SetBodyContact( inst->gl, inst->body_contact, inst->body_contact_offset_m );
		if ( r != PLEAT_RESULT_OK )
		{
			return r;
		}
	}
	return PLEAT_RESULT_OK;
}

// Normals of the rest pose (inst->positions) into inst->normals at creation. The jobs plRunNormals splits over the
// workers, each over its whole range, run here: instance.c sits below instance_deform.c, and the bits are the same.
static plResult plRestNormals( plInstanceData* inst )
{
	const plAssetData* a = inst->asset;
	plFaceNormalsJob faces = { plMakeConstSpan( inst->positions, a->vertex_count, 12 ), a->faces, a->face_count,
							   inst->face_normals, 0, a->face_count, &inst->ctx->kernels };
	plResult r = plFaceNormalsJob_Run( &faces );
	PLEAT_STEP_PHASE( PLEAT_PHASE_FACE_NORMALS );
	if ( r == PLEAT_RESULT_OK )
	{
		plNormalsGatherJob gather = { inst->face_normals,
									  a->face_count,
									  a->adjacency_offsets,
									  a->adjacency_faces,
									  plMakeSpan( inst->normals, a->vertex_count, 12 ),
									  0,
									  a->vertex_count,
									  &inst->ctx->kernels };
		r = plNormalsGatherJob_Run( &gather );
		PLEAT_STEP_PHASE( PLEAT_PHASE_GATHER );
	}
	return r == PLEAT_RESULT_OK ? PLEAT_RESULT_OK : PLEAT_RESULT_INTERNAL_ERROR;
}

plResult plCreateInstance( plContext context, const plInstanceDef* def, plInstance* out_instance )
{
	plContextData* ctx;
	plResult r = plBeginCreate( context, def, out_instance, sizeof( *out_instance ), &ctx );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
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
	if ( def->mlp_backend != PLEAT_MLP_BACKEND_PLEAT && def->mlp_backend != PLEAT_MLP_BACKEND_ONNXRUNTIME &&
		 def->mlp_backend != PLEAT_MLP_BACKEND_GPU )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF, "mlp_backend %d is not a plMlpBackend",
			   (int)def->mlp_backend );
		return PLEAT_RESULT_INVALID_DEF;
	}
	if ( def->gpu_share.index1 != 0 || def->gpu_share.generation != 0 )
	{
		const plInstanceData* share = plGetInstanceData( def->gpu_share );
		if ( share == NULL || share->ctx != ctx || share->asset != a || share->gl == NULL ||
			 share->gpu_mode != def->gpu_mode || share->mlp_backend != def->mlp_backend )
		{
			plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF,
				   "gpu_share: not a live instance of this context and asset with the same gpu_mode and mlp_backend" );
			return PLEAT_RESULT_INVALID_DEF;
		}
	}
	if ( def->mlp_backend == PLEAT_MLP_BACKEND_GPU && def->gpu_mode == PLEAT_GPU_MODE_NONE )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF,
			   "mlp_backend PLEAT_MLP_BACKEND_GPU needs gpu_mode _HOST_CONTEXT or _HEADLESS (the networks run beside "
			   "the deformation)" );
		return PLEAT_RESULT_INVALID_DEF;
	}
	if ( def->gpu_mode != PLEAT_GPU_MODE_NONE && def->gpu_mode != PLEAT_GPU_MODE_HOST_CONTEXT &&
		 def->gpu_mode != PLEAT_GPU_MODE_HEADLESS )
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
	if ( !plBodyContactOffsetValid( def->body_contact_offset_m ) )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF,
			   "body_contact_offset_m %g: must be finite and in 0 .. %g m", (double)def->body_contact_offset_m,
			   (double)PLEAT_BODY_CONTACT_MAX_OFFSET_M );
		return PLEAT_RESULT_INVALID_DEF;
	}
	if ( def->body_contact < PLEAT_BODY_CONTACT_OFF || def->body_contact > PLEAT_BODY_CONTACT_FAST )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF,
			   "body_contact %d: must be 0, PLEAT_BODY_CONTACT_ON (1) or PLEAT_BODY_CONTACT_FAST (2)",
			   def->body_contact );
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
		// One engine joint driving two asset joints would give both the same local rotation: no skeleton means that,
		// it is a map built wrong (a name matched twice), and the garment would bend in two places at once.
		for ( uint32_t j = 1; j < a->joint_count; ++j )
		{
			for ( uint32_t k = 0; k < j; ++k )
			{
				if ( def->joint_map[j] >= 0 && def->joint_map[k] == def->joint_map[j] )
				{
					plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_INSTANCE_BAD_DEF,
						   "joint_map[%u] (asset joint '%s') and joint_map[%u] (asset joint '%s') are both engine joint "
						   "%d: an engine joint drives at most one asset joint",
						   k, a->joint_names + (size_t)k * PLEAT_JOINT_NAME_SIZE, j,
						   a->joint_names + (size_t)j * PLEAT_JOINT_NAME_SIZE, (int)def->joint_map[j] );
					return PLEAT_RESULT_INVALID_DEF;
				}
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
	inst->gpu_mode = def->gpu_mode;
	inst->mlp_backend = def->mlp_backend;
	inst->asset_handle = def->asset;
	inst->user_data = def->user_data;
	inst->network_interval_s = def->network_rate_hz > 0.0f ? 1.0 / def->network_rate_hz : 0.0;
	plSetContactMode( inst, def->body_contact );
	inst->body_contact_offset_m = def->body_contact_offset_m;
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
	size_t p3 = (size_t)a->body_point_count * 3 * sizeof( float );
	size_t sizes[16] = { n3,
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
						 def->gpu_mode != PLEAT_GPU_MODE_NONE ? n3 : 0,
						 a->body_anchors != NULL ? 2 * p3 : 0,
						 // posed points, and a zero row P after them: the empty slots' (plContactRowOffsets)
						 a->body_anchors != NULL
							 ? (size_t)( a->body_point_count + 1 ) * PLEAT_POSED_POINT_FLOATS * sizeof( float )
							 : 0,
						 a->blend_shapes.type == PLEAT_SHAPES_I8 ? a->blend_count * sizeof( float ) : 0 };
	size_t total = 0;
	for ( int i = 0; i < 16; ++i )
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
	float** targets[16] = { &inst->shaped_template, &inst->latent,        &inst->next_latent, &inst->x,
							&inst->y,               &inst->blend_weights, &inst->next_weights, &inst->mlp_scratch,
							&inst->deformed,        &inst->positions,     &inst->normals,     &inst->face_normals,
							&inst->gl_normals,      &inst->shaped_anchors, &inst->posed_points, &inst->shape_weights };
	uint8_t* cursor = (uint8_t*)inst->block;
	for ( int i = 0; i < 16; ++i )
	{
		*targets[i] = sizes[i] != 0 ? (float*)cursor : NULL;
		cursor += plAlign64( sizes[i] );
	}

	int clamped = plClampBeta( a, def->beta, def->beta_count, inst->beta );
	clamped |= plClampMaterial( a, def->material, inst->material, inst->material_normalized );
	// Before the first step: the rest pose, i.e. the shaped template with identity skinning matrices.
	for ( uint32_t j = 0; j < a->joint_count; ++j )
	{
		float* m = inst->skin_matrices + j * 12;
		m[0] = m[5] = m[10] = 1.0f;
	}
	r = plApplyShape( a, inst->beta, inst->shaped_template, inst->rest_joints, inst->shaped_anchors );
	if ( r == PLEAT_RESULT_OK )
	{
		memcpy( inst->positions, inst->shaped_template, n3 );
		memcpy( inst->deformed, inst->shaped_template, n3 );
		r = plRestNormals( inst );
	}
	if ( r == PLEAT_RESULT_OK )
	{
		r = plCreateBackends( inst, def );
	}
	if ( r == PLEAT_RESULT_OK && inst->gl == NULL )
	{
		plReserveBatchScratch( ctx, a->batch_scratch_floats ); // optional: plStepInstances's lanes forms
	}
	if ( r == PLEAT_RESULT_OK && plGlDeformer_HasNetworks( inst->gl ) )
	{
		plReserveBatchScratch( ctx, PLEAT_GPU_GROUP_FLOATS ); // optional: a GPU crowd's large groups (step/batch.c)
	}
	if ( r == PLEAT_RESULT_OK )
	{
		r = plSlotTable_Insert( ctx, &ctx->instances, inst, plInstanceData_Destroy, &out_instance->index1,
								&out_instance->generation );
	}
	a->instance_count += 1;
	if ( r != PLEAT_RESULT_OK )
	{
		plInstanceData_Destroy( ctx, inst );
		return r;
	}
	out_instance->context = ctx->handle;
	plLog( ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_INSTANCE_CREATED, "asset '%s'", a->name );
	return clamped ? PLEAT_RESULT_CLAMPED : PLEAT_RESULT_OK;
}

plResult plDestroyInstance( plInstance handle )
{
	if ( plLookupInstance( handle, __func__ ) == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	plContextData* ctx = plGetContext( handle.context );
	return plSlotTable_Destroy( ctx, &ctx->instances, handle.index1, handle.generation );
}

plResult plInstance_Reset( plInstance handle )
{
	plInstanceData* inst = plLookupInstance( handle, __func__ );
	if ( inst == NULL )
	{
		return PLEAT_RESULT_INVALID_HANDLE;
	}
	inst->history_valid = 0;
	inst->network_pending_s = 0.0;
	inst->network_lead_s = 0.0;
	memset( inst->latent, 0, inst->asset->latent_count * sizeof( float ) );
	return PLEAT_RESULT_OK;
}

plResult plInstance_SetNetworkRate( plInstance handle, float network_rate_hz )
{
	plInstanceData* inst = plLookupInstance( handle, __func__ );
	plResult r = plCheckHandleThenArguments( inst, isfinite( network_rate_hz ) && network_rate_hz >= 0.0f );
	if ( r == PLEAT_RESULT_OK )
	{
		inst->network_interval_s = network_rate_hz > 0.0f ? 1.0 / network_rate_hz : 0.0;
		inst->network_lead_s = 0.0;
	}
	return r;
}

plResult plInstance_SetBodyContact( plInstance handle, int enabled, float offset_m )
{
	plInstanceData* inst = plLookupInstance( handle, __func__ );
	plResult r = plCheckHandleThenArguments( inst, plBodyContactOffsetValid( offset_m ) &&
													   enabled >= PLEAT_BODY_CONTACT_OFF &&
													   enabled <= PLEAT_BODY_CONTACT_FAST );
	if ( r == PLEAT_RESULT_OK && inst->gl != NULL ) // first, so a GL error leaves both paths as they were
	{
		r = plLogIfNoGlContext( inst, plGlDeformer_SetBodyContact( inst->gl, enabled, offset_m ),
								"plInstance_SetBodyContact" );
	}
	if ( r == PLEAT_RESULT_OK )
	{
		plSetContactMode( inst, enabled );
		inst->body_contact_offset_m = offset_m;
	}
	return r;
}

plResult plInstance_SetShape( plInstance handle, const float* beta, uint32_t beta_count )
{
	plInstanceData* inst = plLookupInstance( handle, __func__ );
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
	// The new template and J(β) are built in scratch and go to the GPU (in the GPU modes) before anything else changes,
	// so an error leaves β, J(β) and the template as they were. The scratch is `deformed`: on the CPU path it caches
	// T_def of the committed β only (invalidated here: the next step blends again), on the GPU path it only receives
	// read-backs. The GPU copy is unchanged after a failure too: GL ignores a command that raises an error, and the
	// upload is one BufferSubData.
	inst->deformed_is_committed = 0;
	double rest_joints[PLEAT_MAX_JOINTS * 3];
	float* next_anchors = inst->shaped_anchors != NULL ? inst->shaped_anchors + (size_t)a->body_point_count * 3 : NULL;
	plResult r = plApplyShape( a, clamped_beta, inst->deformed, rest_joints, next_anchors );
	if ( r == PLEAT_RESULT_OK && inst->gl != NULL )
	{
		r = plLogIfNoGlContext( inst, plGlDeformer_SetShapedTemplate( inst->gl, inst->deformed, next_anchors ),
								"plInstance_SetShape" );
	}
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	memcpy( inst->beta, clamped_beta, a->beta_count * sizeof( float ) );
	memcpy( inst->shaped_template, inst->deformed, (size_t)a->vertex_count * 3 * sizeof( float ) );
	if ( next_anchors != NULL )
	{
		memcpy( inst->shaped_anchors, next_anchors, (size_t)a->body_point_count * 3 * sizeof( float ) );
	}
	memcpy( inst->rest_joints, rest_joints, (size_t)a->joint_count * 3 * sizeof( double ) );
	if ( clamped )
	{
		plLog( inst->ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_INSTANCE_INPUT_CLAMPED, "beta" );
	}
	return clamped ? PLEAT_RESULT_CLAMPED : PLEAT_RESULT_OK;
}

plResult plInstance_SetMaterial( plInstance handle, const float material[4] )
{
	plInstanceData* inst = plLookupInstance( handle, __func__ );
	plResult r = plCheckHandleThenArguments( inst, material != NULL );
	if ( r == PLEAT_RESULT_OK && !plAllFiniteFloats( material, 4 ) )
	{
		r = PLEAT_RESULT_NON_FINITE_INPUT;
	}
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	int clamped = plClampMaterial( inst->asset, material, inst->material, inst->material_normalized );
	if ( clamped )
	{
		plLog( inst->ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_INSTANCE_INPUT_CLAMPED, "material" );
	}
	return clamped ? PLEAT_RESULT_CLAMPED : PLEAT_RESULT_OK;
}
