// Batches: one dispatch per shader for many instances of one mesh (plGlDeformer_RunBatch). The lead deformer keeps a
// block per member at each per-instance binding and copies the members' outputs to their own buffers (docs/gpu.md).
#include "gl_deformer_data.h"
#include "gl_shaders.h"
#include <stdatomic.h>
#include <stddef.h>
#include <string.h>

// ---- batches: one dispatch per shader for many instances of one mesh ----

int plGlDeformer_CanBatch( const plGlDeformer* lead, const plGlDeformer* member )
{
	return lead != NULL && member != NULL && lead->mode == member->mode && lead->vertex_count == member->vertex_count &&
		   lead->face_count == member->face_count && lead->blend_count == member->blend_count &&
		   lead->influence_count == member->influence_count && lead->joint_count == member->joint_count &&
		   lead->anchor_influence_count == member->anchor_influence_count &&
		   lead->point_count == member->point_count && lead->candidate_count == member->candidate_count &&
		   lead->point_ring_count == member->point_ring_count &&
		   lead->networks.lp_count == member->networks.lp_count &&
		   lead->networks.dec_count == member->networks.dec_count &&
		   lead->networks.input_count == member->networks.input_count &&
		   lead->networks.latent_count == member->networks.latent_count;
}

// The batch's host memory (the template keys and the staging block), freed and forgotten.
static void plFreeBatchHostMemory( plGlDeformer* lead, plGlBatchBuffers* batch )
{
	plFree( &lead->allocator, batch->template_keys, batch->template_keys_bytes );
	plFree( &lead->allocator, batch->staging, batch->staging_bytes );
	batch->template_keys = NULL;
	batch->template_keys_bytes = 0;
	batch->staging = NULL;
	batch->staging_bytes = 0;
}

// The per-instance buffers for `capacity` members (the first batch, or a larger one than before: the old ones go).
// Between plBegin and plEnd.
static plResult plReserveBatch( plGlDeformer* lead, uint32_t capacity )
{
	plGlBatchBuffers* batch = &lead->batch;
	if ( capacity <= batch->capacity )
		return PLEAT_RESULT_OK;
	const plGlApi* api = &lead->api;
	for ( int b = 0; b < PLEAT_GL_BINDING_COUNT; ++b )
	{
		if ( batch->buffers[b] != 0 )
			api->DeleteBuffers( 1, &batch->buffers[b] );
		batch->buffers[b] = 0;
	}
	plFreeBatchHostMemory( lead, batch );
	batch->capacity = 0;

	size_t c = capacity, n = lead->vertex_count, f = lead->face_count, p = lead->point_count;
	size_t rows = plGlShapedRows( lead );
	size_t weights = c * lead->blend_count * 4, matrices = c * lead->joint_count * 48, contact = c * 16;
	batch->staging_bytes = weights > matrices ? weights : matrices;
	batch->staging_bytes = batch->staging_bytes > contact ? batch->staging_bytes : contact;
	batch->staging = plAlloc( &lead->allocator, batch->staging_bytes, 64 );
	batch->template_keys_bytes = c * 2 * sizeof( uint64_t );
	batch->template_keys = plAllocZeroed( &lead->allocator, batch->template_keys_bytes, 16 );
	if ( batch->staging == NULL || batch->template_keys == NULL )
	{
		plFreeBatchHostMemory( lead, batch );
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	batch->buffers[PLEAT_GL_BINDING_SHAPED_TEMPLATE] = plGlNewStorageBuffer( api, c * rows * 16, NULL, GL_DYNAMIC_COPY );
	batch->buffers[PLEAT_GL_BINDING_BLEND_WEIGHTS] = plGlNewStorageBuffer( api, weights, NULL, GL_DYNAMIC_COPY );
	batch->buffers[PLEAT_GL_BINDING_DEFORMED] = plGlNewStorageBuffer( api, c * n * 16, NULL, GL_DYNAMIC_COPY );
	batch->buffers[PLEAT_GL_BINDING_SKIN_MATRICES] = plGlNewStorageBuffer( api, matrices, NULL, GL_DYNAMIC_COPY );
	batch->buffers[PLEAT_GL_BINDING_POSITIONS] = plGlNewStorageBuffer( api, c * n * 16, NULL, GL_DYNAMIC_COPY );
	batch->buffers[PLEAT_GL_BINDING_NORMALS] = plGlNewStorageBuffer( api, c * n * 16, NULL, GL_DYNAMIC_COPY );
	batch->buffers[PLEAT_GL_BINDING_FACE_NORMALS] = plGlNewStorageBuffer( api, c * f * 16, NULL, GL_DYNAMIC_COPY );
	batch->buffers[PLEAT_GL_BINDING_BATCH_CONTACT] = plGlNewStorageBuffer( api, contact, NULL, GL_DYNAMIC_COPY );
	if ( p > 0 )
		batch->buffers[PLEAT_GL_BINDING_POSED_POINTS] = plGlNewStorageBuffer( api, c * p * 32, NULL, GL_DYNAMIC_COPY );
	if ( p > 0 && batch->points_program == 0 )
	{
		batch->points_program = plGlCompileProgram( api, plGlShaderSource_body_contact,
												  PLEAT_GL_POSE_POINTS_DEFINES PLEAT_GL_BATCH_DEFINES );
		if ( batch->points_program == 0 )
			return PLEAT_RESULT_GL_ERROR;
	}
	if ( lead->point_ring_count > 0 && batch->normals_program == 0 )
	{
		batch->normals_program = plGlCompileProgram( api, plGlShaderSource_body_contact,
												   PLEAT_GL_POINT_NORMALS_DEFINES PLEAT_GL_BATCH_DEFINES );
		if ( batch->normals_program == 0 )
			return PLEAT_RESULT_GL_ERROR;
	}
	if ( p > 0 && batch->contact_program == 0 )
	{
		batch->contact_program =
			plGlCompileProgram( api, plGlShaderSource_body_contact, PLEAT_GL_CONTACT_DEFINES PLEAT_GL_BATCH_DEFINES );
		if ( batch->contact_program == 0 )
			return PLEAT_RESULT_GL_ERROR;
	}
	plResult result = plGlCheckErrors( api );
	if ( result == PLEAT_RESULT_OK )
		batch->capacity = capacity; // else the keys stay unset and the next batch tries again
	return result;
}

// Reads rows [first, first + N) of a vec4 buffer back into out [N][3].
static void plReadBackRows( plGlDeformer* deformer, GLuint buffer, size_t first, float* out )
{
	const plGlApi* api = &deformer->api;
	plGlVec4* rows = deformer->staging;
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, buffer );
	api->GetBufferSubData( GL_SHADER_STORAGE_BUFFER, (GLintptr)( first * 16 ), (GLsizeiptr)deformer->vertex_count * 16,
						   rows );
	for ( uint32_t i = 0; i < deformer->vertex_count; ++i )
	{
		out[3 * i] = rows[i].x;
		out[3 * i + 1] = rows[i].y;
		out[3 * i + 2] = rows[i].z;
	}
}

// The batch's per-instance inputs: each member's shaped template (only where the slot holds another one), all blend
// weights and skinning matrices (one upload each), the body-contact settings.
static void plUploadBatchInputs( plGlDeformer* lead, const plGlBatchMember* members, uint32_t count )
{
	const plGlApi* api = &lead->api;
	plGlBatchBuffers* batch = &lead->batch;
	uint32_t n = lead->vertex_count;
	int points = lead->point_count > 0;
	size_t rows = plGlShapedRows( lead );
	for ( uint32_t k = 0; k < count; ++k )
	{
		const plGlDeformer* own = members[k].deformer;
		uint64_t* key = batch->template_keys + 2 * (size_t)k;
		if ( key[0] == own->serial && key[1] == own->template_generation )
			continue;
		plGlVec4* staging = lead->staging; // holds N + P rows (plCreate sized it)
		plGlToVec4( staging, members[k].shaped_template, n, 1.0f );
		if ( points )
			plGlToVec4( staging + n, members[k].body_anchors, lead->point_count, 1.0f );
		api->BindBuffer( GL_SHADER_STORAGE_BUFFER, batch->buffers[PLEAT_GL_BINDING_SHAPED_TEMPLATE] );
		api->BufferSubData( GL_SHADER_STORAGE_BUFFER, (GLintptr)( k * rows * 16 ), (GLsizeiptr)( rows * 16 ), staging );
		key[0] = own->serial;
		key[1] = own->template_generation;
	}
	float* weights = batch->staging;
	for ( uint32_t k = 0; k < count; ++k )
		memcpy( weights + (size_t)k * lead->blend_count, members[k].blend_weights, lead->blend_count * sizeof( float ) );
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, batch->buffers[PLEAT_GL_BINDING_BLEND_WEIGHTS] );
	api->BufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)count * lead->blend_count * 4, weights );
	float* matrices = batch->staging;
	for ( uint32_t k = 0; k < count; ++k )
		memcpy( matrices + (size_t)k * lead->joint_count * 12, members[k].skin_matrices,
				(size_t)lead->joint_count * 48 );
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, batch->buffers[PLEAT_GL_BINDING_SKIN_MATRICES] );
	api->BufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)count * lead->joint_count * 48, matrices );
	if ( points )
	{
		plGlVec4* contact = batch->staging;
		for ( uint32_t k = 0; k < count; ++k )
		{
			const plGlDeformer* own = members[k].deformer;
			contact[k] = ( plGlVec4 ){ own->body_contact ? 1.0f : 0.0f, own->body_contact_offset_m, 0.0f, 0.0f };
		}
		api->BindBuffer( GL_SHADER_STORAGE_BUFFER, batch->buffers[PLEAT_GL_BINDING_BATCH_CONTACT] );
		api->BufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)count * 16, contact );
	}
}

// Every member's outputs where its own Run leaves them: host buffers (copied on the GPU) and the read-backs.
static void plDeliverBatchOutputs( plGlDeformer* lead, const plGlBatchMember* members, uint32_t count )
{
	const plGlApi* api = &lead->api;
	const plGlBatchBuffers* batch = &lead->batch;
	size_t bytes = (size_t)lead->vertex_count * 16;
	for ( uint32_t k = 0; k < count; ++k )
	{
		const plGlDeformer* own = members[k].deformer;
		const plGlBinding outputs[2] = { PLEAT_GL_BINDING_POSITIONS, PLEAT_GL_BINDING_NORMALS };
		for ( int o = 0; o < 2; ++o )
		{
			if ( own->mode == PLEAT_GL_DEFORMER_HOST_CONTEXT && own->owned[outputs[o]] == 0 )
			{
				// The engine's vertex buffer (its contents are the engine's, so one whole-range copy per output).
				api->BindBuffer( GL_COPY_READ_BUFFER, batch->buffers[outputs[o]] );
				api->BindBuffer( GL_COPY_WRITE_BUFFER, own->bindings[outputs[o]] );
				api->CopyBufferSubData( GL_COPY_READ_BUFFER, GL_COPY_WRITE_BUFFER, (GLintptr)( k * bytes ), 0,
										(GLsizeiptr)bytes );
			}
		}
		if ( members[k].positions != NULL )
			plReadBackRows( lead, batch->buffers[PLEAT_GL_BINDING_POSITIONS], (size_t)k * lead->vertex_count,
							members[k].positions );
		if ( members[k].normals != NULL )
			plReadBackRows( lead, batch->buffers[PLEAT_GL_BINDING_NORMALS], (size_t)k * lead->vertex_count,
							members[k].normals );
	}
}

plResult plGlDeformer_RunBatch( plGlDeformer* lead, const plGlBatchMember* members, uint32_t count )
{
	if ( lead == NULL || members == NULL || count == 0 || count > PLEAT_GL_BATCH_MAX )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	for ( uint32_t k = 0; k < count; ++k )
	{
		const plGlBatchMember* m = &members[k];
		if ( !plGlDeformer_CanBatch( lead, m->deformer ) || m->shaped_template == NULL || m->blend_weights == NULL ||
			 m->skin_matrices == NULL || ( lead->anchor_influence_count > 0 && m->body_anchors == NULL ) )
			return PLEAT_RESULT_INVALID_ARGUMENT;
		if ( m->network_input != NULL && ( lead->networks.lp_count == 0 || m->latent_out == NULL ||
										   m->weights_out == NULL || m->latent_finite_out == NULL ) )
			return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plResult result = plGlBegin( lead );
	if ( result != PLEAT_RESULT_OK )
		return result;
	const plGlApi* api = &lead->api;
	plGlCheckErrors( api ); // an error the engine left pending is not ours to report
	result = plReserveBatch( lead, count );
	if ( result != PLEAT_RESULT_OK )
	{
		plGlCheckErrors( api );
		plGlEnd( lead );
		return result;
	}
	plUploadBatchInputs( lead, members, count );

	api->BindBufferBase( GL_UNIFORM_BUFFER, PLEAT_GL_PARAMS_BINDING, lead->params_buffer );
	for ( GLuint b = 0; b < PLEAT_GL_BINDING_NETWORK_WEIGHTS; ++b )
	{
		GLuint buffer = lead->batch.buffers[b] != 0 ? lead->batch.buffers[b] : lead->bindings[b];
		api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, b, buffer );
	}
	// The networks of the members that run them, writing their weights into the buffer the blend reads.
	int timed = atomic_load_explicit( &g_plGlTimeBatches, memory_order_relaxed ) != 0;
	if ( timed && lead->batch.timer_queries[0] == 0 )
		api->GenQueries( 2, lead->batch.timer_queries );
	if ( timed )
		api->BeginQuery( GL_TIME_ELAPSED, lead->batch.timer_queries[0] );
	uint32_t networks_ran = 0;
	result = plGlNetworks_Run( lead, members, count, &networks_ran );
	if ( timed )
		api->EndQuery( GL_TIME_ELAPSED );
	if ( result != PLEAT_RESULT_OK )
	{
		plGlCheckErrors( api );
		plGlEnd( lead );
		return result;
	}
	int contact = 0;
	for ( uint32_t k = 0; k < count; ++k )
		contact |= members[k].deformer->body_contact;

	// The single Run's dispatches with the members in y: one per pass for the whole batch.
	if ( timed )
		api->BeginQuery( GL_TIME_ELAPSED, lead->batch.timer_queries[1] );
	if ( contact )
		plGlRunShaders( lead, lead->batch.points_program, lead->batch.normals_program, lead->batch.contact_program,
					  count );
	else
		plGlRunShaders( lead, 0, 0, 0, count );
	if ( timed )
	{
		api->EndQuery( GL_TIME_ELAPSED );
		GLuint64 network_ns = 0, deform_ns = 0;
		api->GetQueryObjectui64v( lead->batch.timer_queries[0], GL_QUERY_RESULT, &network_ns );
		api->GetQueryObjectui64v( lead->batch.timer_queries[1], GL_QUERY_RESULT, &deform_ns );
		atomic_fetch_add_explicit( &g_plGlNetworkNs, network_ns, memory_order_relaxed );
		atomic_fetch_add_explicit( &g_plGlDeformNs, deform_ns, memory_order_relaxed );
	}

	plDeliverBatchOutputs( lead, members, count );
	if ( networks_ran > 0 )
		plGlNetworks_ReadBack( lead, members, count );
	result = plGlCheckErrors( api );
	if ( result != PLEAT_RESULT_OK )
	{
		// The templates may not have arrived: upload them all again next time.
		memset( lead->batch.template_keys, 0, (size_t)lead->batch.capacity * 2 * sizeof( uint64_t ) );
	}
	plGlEnd( lead );
	return result;
}
