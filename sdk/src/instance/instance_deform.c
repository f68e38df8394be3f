// The CPU deformation of an instance: blend shapes → skinning → normals, each a job over an index range so the host's
// workers can split it (pleat.h, THREADING). The outputs do not depend on the split: every job sums in a fixed order.
#include "instance.h"
#include "core/step_phases.h"

#include <stdatomic.h>

typedef struct plDeformTask
{
	plInstanceData* inst;
	const plDeformSpans* spans;
	int fast_contact;  // plRunsFastContact for this deformation
	atomic_int result; // a job's error (plResult), written by whichever worker saw one; PLEAT_RESULT_OK otherwise
} plDeformTask;

// Workers cannot return a result: a failing job leaves its code in the task's slot for the caller to return after
// the task (plDeformCpu, and the normals tasks below).
static void plRecordJobResult( atomic_int* slot, plResult r )
{
	if ( r != PLEAT_RESULT_OK )
	{
		atomic_store_explicit( slot, (int)r, memory_order_relaxed );
	}
}

static void plBlendAndSkinTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plDeformTask* t = (plDeformTask*)context;
	plInstanceData* inst = t->inst;
	const plDeformSpans* d = t->spans;
	const plAssetData* a = inst->asset;
	uint32_t n = a->vertex_count;
	if ( d->blend )
	{
		plBlendShapesJob blend = { plMakeConstSpan( inst->shaped_template, n, 12 ), a->blend_shapes,
								   plMakeConstSpan( d->blend_weights, a->blend_count, 4 ),
								   plMakeSpan( inst->deformed, n, 12 ), begin, end, &inst->ctx->kernels };
		plRecordJobResult( &t->result, plBlendShapesJob_Run( &blend ) );
		PLEAT_STEP_PHASE( PLEAT_PHASE_BLEND );
	}
	plSkinningJob skin = { plMakeConstSpan( d->rest, n, 12 ),
						   a->skin_indices,
						   a->skin_weights,
						   a->influence_count,
						   d->skin_matrices,
						   a->joint_count,
						   plMakeSpan( d->positions, n, 12 ),
						   begin,
						   end,
						   &inst->ctx->kernels,
						   a->skin_column_offsets };
	plRecordJobResult( &t->result, plSkinningJob_Run( &skin ) );
	PLEAT_STEP_PHASE( PLEAT_PHASE_SKIN );
	if ( inst->body_contact )
	{
		plRecordJobResult( &t->result, t->fast_contact
									? plRunFastBodyContact( inst, d->positions, d->skin_matrices, begin, end )
									: plPushOutOfBody( inst, d->positions, begin, end ) );
		PLEAT_STEP_PHASE( PLEAT_PHASE_CONTACT );
	}
}

// Before the blend-and-skin task: the body points in this pose, which any vertex's push may read, then (a second
// task: they read the posed points around them) the posed body's normals at the points with rings.
static void plPoseBodyPointsTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plDeformTask* t = (plDeformTask*)context;
	plRecordJobResult( &t->result, plPoseBodyPoints( t->inst, t->spans->skin_matrices, begin, end ) );
}

static void plBodyPointNormalsTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plDeformTask* t = (plDeformTask*)context;
	plRecordJobResult( &t->result, plBodyPointNormals( t->inst, begin, end ) );
}

plResult plBodyPointNormals( plInstanceData* inst, uint32_t begin, uint32_t end )
{
	const plAssetData* a = inst->asset;
	if ( a->body_anchor_ring == NULL )
	{
		return PLEAT_RESULT_OK; // asset 1.1: the blended rest normals stand
	}
	plBodyPointNormalsJob job = { inst->posed_points,
								  a->body_point_count,
								  a->body_anchor_ring,
								  a->body_anchor_ring_count,
								  begin,
								  end,
								  &inst->ctx->kernels,
								  a->body_anchor_ring_lanes };
	return plBodyPointNormalsJob_Run( &job );
}

plResult plPoseBodyPoints( plInstanceData* inst, const float* skin_matrices, uint32_t begin, uint32_t end )
{
	const plAssetData* a = inst->asset;
	plBodyPointsJob job = { inst->shaped_anchors,
							a->body_anchor_normals,
							a->body_anchor_skin_indices,
							a->body_anchor_skin_weights,
							a->body_anchor_influence_count,
							skin_matrices,
							a->joint_count,
							inst->posed_points,
							a->body_point_count,
							begin,
							end,
							&inst->ctx->kernels,
							a->body_anchor_ring, // plBodyPointNormals follows every posing
							a->body_anchor_ring_count,
							a->body_anchor_column_offsets };
	return plBodyPointsJob_Run( &job );
}

plResult plPushOutOfBody( plInstanceData* inst, float* positions, uint32_t begin, uint32_t end )
{
	const plAssetData* a = inst->asset;
	plBodyContactJob job = { plMakeSpan( positions, a->vertex_count, 12 ),
							 inst->posed_points,
							 a->body_point_count,
							 a->body_anchor_candidates,
							 a->body_anchor_candidate_count,
							 inst->body_contact_offset_m,
							 begin,
							 end,
							 &inst->ctx->kernels,
							 a->body_contact_row_offsets };
	return plBodyContactJob_Run( &job );
}

plResult plRunFastBodyContact( plInstanceData* inst, float* positions, const float* skin_matrices, uint32_t begin,
							   uint32_t end )
{
	const plAssetData* a = inst->asset;
	// rows 0..N-1 of the points are the vertices' own (plAssetData.body_contact_fast_ready)
	plBodyContactFastJob job = { plMakeSpan( positions, a->vertex_count, 12 ),
								 inst->shaped_anchors,
								 a->body_anchor_normals,
								 a->body_anchor_skin_indices,
								 a->body_anchor_skin_weights,
								 a->body_anchor_influence_count,
								 skin_matrices,
								 a->joint_count,
								 inst->body_contact_offset_m,
								 begin,
								 end,
								 &inst->ctx->kernels,
								 a->body_anchor_column_offsets }; // the first N points' rows are the vertices' anchors
	return plBodyContactFastJob_Run( &job );
}

plResult plRunBodyContact( plInstanceData* inst, float* positions, const float* skin_matrices, int fast )
{
	if ( plRunsFastContact( inst, fast ) )
	{
		return plRunFastBodyContact( inst, positions, skin_matrices, 0, inst->asset->vertex_count );
	}
	uint32_t P = inst->asset->body_point_count;
	plResult r = plPoseBodyPoints( inst, skin_matrices, 0, P );
	r = r == PLEAT_RESULT_OK ? plBodyPointNormals( inst, 0, P ) : r;
	return r == PLEAT_RESULT_OK ? plPushOutOfBody( inst, positions, 0, inst->asset->vertex_count ) : r;
}

static void plDeformTask_Init( plDeformTask* task, plInstanceData* inst, const plDeformSpans* spans )
{
	task->inst = inst;
	task->spans = spans;
	task->fast_contact = plRunsFastContact( inst, spans->force_fast_contact );
	atomic_init( &task->result, (int)PLEAT_RESULT_OK );
}

// A job that rejects the spans the instance built for it is a defect of the SDK, not of the call.
static plResult plDeformTask_Result( plDeformTask* task )
{
	return atomic_load_explicit( &task->result, memory_order_relaxed ) == (int)PLEAT_RESULT_OK
			   ? PLEAT_RESULT_OK
			   : PLEAT_RESULT_INTERNAL_ERROR;
}

// ---- normals: the one rule for which jobs compute them ----

typedef struct plNormalsTask
{
	plInstanceData* inst;
	const float* positions;
	float* normals;
	atomic_int result;
} plNormalsTask;

static void plFaceNormalsTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plNormalsTask* t = (plNormalsTask*)context;
	const plAssetData* a = t->inst->asset;
	plFaceNormalsJob job = { plMakeConstSpan( t->positions, a->vertex_count, 12 ), a->faces, a->face_count,
							 t->inst->face_normals, begin, end, &t->inst->ctx->kernels };
	plRecordJobResult( &t->result, plFaceNormalsJob_Run( &job ) );
	PLEAT_STEP_PHASE( PLEAT_PHASE_FACE_NORMALS );
}

static void plNormalsGatherTask( uint32_t begin, uint32_t end, uint32_t worker, void* context )
{
	(void)worker;
	plNormalsTask* t = (plNormalsTask*)context;
	const plAssetData* a = t->inst->asset;
	plNormalsGatherJob job = { t->inst->face_normals,
							   a->face_count,
							   a->adjacency_offsets,
							   a->adjacency_faces,
							   plMakeSpan( t->normals, a->vertex_count, 12 ),
							   begin,
							   end,
							   &t->inst->ctx->kernels };
	plRecordJobResult( &t->result, plNormalsGatherJob_Run( &job ) );
	PLEAT_STEP_PHASE( PLEAT_PHASE_GATHER );
}

plResult plRunNormals( plInstanceData* inst, const float* positions, float* normals, const plTaskRunner* runner )
{
	const plAssetData* a = inst->asset;
	if ( !plTaskRunner_IsParallel( runner ) && a->face_count >= a->vertex_count )
	{
		// One thread: one pass over the faces scattering into per-vertex sums (the face-normal scratch, [F][4] with
		// F ≥ N, holds them), bit-identical to the face-normal + gather split that workers share.
		plNormalsScatterJob scatter = { plMakeConstSpan( positions, a->vertex_count, 12 ), a->faces, a->face_count,
										plMakeSpan( normals, a->vertex_count, 12 ), inst->face_normals,
										a->face_count, &inst->ctx->kernels };
		plResult r = plNormalsScatterJob_Run( &scatter );
		PLEAT_STEP_PHASE( PLEAT_PHASE_GATHER );
		return r == PLEAT_RESULT_OK ? PLEAT_RESULT_OK : PLEAT_RESULT_INTERNAL_ERROR;
	}
	plNormalsTask task;
	task.inst = inst;
	task.positions = positions;
	task.normals = normals;
	atomic_init( &task.result, (int)PLEAT_RESULT_OK );
	plRunTask( runner, plFaceNormalsTask, a->face_count, 512, &task );
	if ( atomic_load_explicit( &task.result, memory_order_relaxed ) == (int)PLEAT_RESULT_OK )
	{
		plRunTask( runner, plNormalsGatherTask, a->vertex_count, 256, &task );
	}
	return atomic_load_explicit( &task.result, memory_order_relaxed ) == (int)PLEAT_RESULT_OK
			   ? PLEAT_RESULT_OK
			   : PLEAT_RESULT_INTERNAL_ERROR;
}

const float* plBlendKernelWeights( plInstanceData* inst, const float* weights )
{
	const plAssetData* a = inst->asset;
	if ( a->blend_shapes.type != PLEAT_SHAPES_I8 )
	{
		return weights;
	}
	plFoldShapeScales( inst->shape_weights, weights, &a->blend_shapes, a->blend_count );
	return inst->shape_weights;
}

plResult plDeformCpu( plInstanceData* inst, const plDeformSpans* spans, const plTaskRunner* runner )
{
	const plAssetData* a = inst->asset;
	plDeformSpans folded = *spans; // the blend's weights as the kernels take them, once for every vertex range
	if ( spans->blend )
	{
		folded.blend_weights = plBlendKernelWeights( inst, spans->blend_weights );
		spans = &folded;
	}
	plDeformTask task;
	plDeformTask_Init( &task, inst, spans );
	if ( inst->body_contact && !task.fast_contact )
	{
		plRunTask( runner, plPoseBodyPointsTask, a->body_point_count, 512, &task );
		if ( a->body_anchor_ring != NULL && plDeformTask_Result( &task ) == PLEAT_RESULT_OK )
		{
			plRunTask( runner, plBodyPointNormalsTask, a->body_point_count, 512, &task );
		}
		if ( plDeformTask_Result( &task ) != PLEAT_RESULT_OK )
		{
			return plDeformTask_Result( &task );
		}
		PLEAT_STEP_PHASE( PLEAT_PHASE_CONTACT );
	}
	plRunTask( runner, plBlendAndSkinTask, a->vertex_count, 256, &task );
	if ( plDeformTask_Result( &task ) != PLEAT_RESULT_OK )
	{
		return plDeformTask_Result( &task );
	}
	return plRunNormals( inst, spans->positions, spans->normals, runner );
}
