// The GL compute path: blend_shapes.comp → skinning.comp (→ body_contact.comp: posing the body points, their normals
// from the posed rings where the asset has them, then the push)
// → face_normals.comp → normals_gather.comp over GPU-resident asset data, for one instance (plGlDeformer_Run; a
// batch of instances of one mesh, one dispatch per pass, is gl_batch.c's plGlDeformer_RunBatch). See
// sdk/src/backends/gl_deformer.h for the contract and docs/gpu.md for the buffers, the saved state and the
// measurements.
#include "gl_deformer_data.h"
#include "gl_shaders.h"
#include <stddef.h>
#include <stdio.h>
#include <string.h>

_Atomic int g_plGlTimeBatches;
_Atomic uint64_t g_plGlNetworkNs, g_plGlDeformNs;

// A deformer's identity for a batch's template cache (pointers are reused after a free; serials are not).
static _Atomic uint64_t s_plGlDeformerSerial;

// Non-zero if some GL context is current on the calling thread. GL calls made without one do nothing and raise no
// error (glGetError answers GL_NO_ERROR too), so without this check an upload or a run "succeeds" having done nothing;
// glGetString is the one query every GL answers with NULL when no context is current (through libepoxy, for GLX and
// EGL alike, which is how the engine's context is reached).
static int plHostContextIsCurrent( const plGlApi* api )
{
	return api->GetString( GL_VERSION ) != NULL;
}

// Makes the deformer's GL usable for one call: headless → make our context current; host → check that the engine has
// a context current (GL_UNAVAILABLE if not, before anything is touched), then save its state.
plResult plGlBegin( plGlDeformer* deformer )
{
	if ( deformer->mode == PLEAT_GL_DEFORMER_HEADLESS )
		return plGlContext_Enter( deformer->context );
	if ( !plHostContextIsCurrent( &deformer->api ) )
		return PLEAT_RESULT_GL_UNAVAILABLE;
	plGlSaveState( &deformer->api, deformer->binding_count, &deformer->saved );
	return PLEAT_RESULT_OK;
}

void plGlEnd( plGlDeformer* deformer )
{
	if ( deformer->mode == PLEAT_GL_DEFORMER_HEADLESS )
		plGlContext_Leave( deformer->context );
	else
		plGlRestoreState( &deformer->api, deformer->binding_count, &deformer->saved );
}

static plResult plValidateDesc( const plGlDeformerDesc* desc )
{
	if ( desc->vertex_count == 0 || desc->face_count == 0 || desc->blend_count == 0 || desc->joint_count == 0 ||
		 desc->influence_count == 0 || desc->influence_count > 8 )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	if ( desc->shaped_template == NULL || desc->blend_shapes.data == NULL || desc->skin_indices == NULL ||
		 desc->skin_weights == NULL || desc->faces == NULL || desc->adjacency_offsets == NULL ||
		 desc->adjacency_faces == NULL )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	// Buffer sizes below are computed in size_t/GLsizeiptr; keep every one well inside 2^31 bytes.
	uint64_t n = desc->vertex_count;
	if ( n * 16u * desc->blend_count > 0x7fffffffu || n * 4u * desc->influence_count > 0x7fffffffu ||
		 (uint64_t)desc->face_count * 12u > 0x7fffffffu || (uint64_t)desc->joint_count * 48u > 0x7fffffffu )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	if ( desc->mode == PLEAT_GL_DEFORMER_HEADLESS && ( desc->host_position_buffer != 0 || desc->host_normal_buffer != 0 ) )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	if ( desc->networks != NULL )
	{
		plResult networks = plGlNetworks_Validate( desc->networks, desc->blend_count );
		if ( networks != PLEAT_RESULT_OK )
			return networks;
	}
	if ( desc->body_anchors != NULL )
	{
		// As plBodyContactJob_Validate: without a candidate table vertex v's point is v, so there are at least N.
		uint64_t p = desc->body_point_count, c = desc->body_anchor_candidate_count;
		if ( desc->body_anchor_normals == NULL || desc->body_anchor_skin_indices == NULL ||
			 desc->body_anchor_skin_weights == NULL || desc->body_anchor_influence_count == 0 ||
			 desc->body_anchor_influence_count > 8 || p == 0 ||
			 ( desc->body_anchor_candidates == NULL ? c != 1 || p < n : c < 1 || c > PLEAT_MAX_CONTACT_CANDIDATES ) )
			return PLEAT_RESULT_INVALID_ARGUMENT;
		uint64_t r = desc->body_anchor_ring_count;
		if ( desc->body_anchor_ring == NULL ? r != 0 : r < 3 || r > PLEAT_MAX_POINT_RING )
			return PLEAT_RESULT_INVALID_ARGUMENT;
		if ( ( n + p ) * 16u > 0x7fffffffu || p * 32u > 0x7fffffffu || n * 4u * c > 0x7fffffffu ||
			 p * 4u * r > 0x7fffffffu )
			return PLEAT_RESULT_INVALID_ARGUMENT;
		for ( size_t e = 0; e < (size_t)p * desc->body_anchor_influence_count; ++e )
		{
			if ( desc->body_anchor_skin_indices[e] >= desc->joint_count )
				return PLEAT_RESULT_INVALID_ARGUMENT;
		}
		// Candidate and ring indices need no check: the push skips any index >= P as an empty slot, and a ring ends at
		// its first index >= P (as plBodyPointNormals_Scalar).
	}
	// The shaders index with these values unchecked, so they are checked once here (an out-of-range GPU read is
	// undefined behaviour without robust buffer access).
	for ( size_t e = 0; e < (size_t)desc->vertex_count * desc->influence_count; ++e )
	{
		if ( desc->skin_indices[e] >= desc->joint_count )
			return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	for ( size_t e = 0; e < (size_t)desc->face_count * 3u; ++e )
	{
		if ( desc->faces[e] >= desc->vertex_count )
			return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( desc->adjacency_offsets[0] != 0 || desc->adjacency_offsets[desc->vertex_count] > 3u * desc->face_count )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	for ( uint32_t i = 0; i < desc->vertex_count; ++i )
	{
		if ( desc->adjacency_offsets[i + 1] < desc->adjacency_offsets[i] )
			return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	for ( uint32_t e = 0; e < desc->adjacency_offsets[desc->vertex_count]; ++e )
	{
		if ( desc->adjacency_faces[e] >= desc->face_count )
			return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	return PLEAT_RESULT_OK;
}

int plGlBindingIsStatic( plGlBinding binding )
{
	switch ( binding )
	{
	case PLEAT_GL_BINDING_BLEND_SHAPES:
	case PLEAT_GL_BINDING_SKIN_INDICES:
	case PLEAT_GL_BINDING_SKIN_WEIGHTS:
	case PLEAT_GL_BINDING_FACES:
	case PLEAT_GL_BINDING_ADJACENCY_OFFSETS:
	case PLEAT_GL_BINDING_ADJACENCY_FACES:
	case PLEAT_GL_BINDING_ANCHOR_NORMALS:
	case PLEAT_GL_BINDING_ANCHOR_SKIN_INDICES:
	case PLEAT_GL_BINDING_ANCHOR_SKIN_WEIGHTS:
	case PLEAT_GL_BINDING_BATCH_CONTACT: // a single Run's 16-byte placeholder
	case PLEAT_GL_BINDING_CONTACT_CANDIDATES:
	case PLEAT_GL_BINDING_POINT_RINGS:
		return 1;
	default:
		return 0;
	}
}

// A buffer at a binding: the deformer's own, or for a static binding the shared block's.
static GLuint plCreateBuffer( plGlDeformer* deformer, plGlBinding binding, size_t bytes, const void* data, GLenum usage )
{
	GLuint buffer = plGlNewStorageBuffer( &deformer->api, bytes, data, usage );
	if ( plGlBindingIsStatic( binding ) )
		deformer->shared->buffers[binding] = buffer;
	else
		deformer->owned[binding] = buffer;
	deformer->bindings[binding] = buffer;
	return buffer;
}

// [count][3] → vec4 rows (w = w_value).
void plGlToVec4( plGlVec4* rows, const float* xyz, uint32_t count, float w_value )
{
	for ( uint32_t i = 0; i < count; ++i )
		rows[i] = ( plGlVec4 ){ xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], w_value };
}

// Rows of the shaped-template buffer per instance: the template, then (with body points) the P points of the same β.
size_t plGlShapedRows( const plGlDeformer* deformer )
{
	return (size_t)deformer->vertex_count + deformer->point_count;
}

// The shaped template, then (with body points) the points of the same β in rows N..N+P−1: one BufferSubData, so a GL
// error leaves both as they were.
static void plUploadShapedTemplate( plGlDeformer* deformer, const float* shaped_template, const float* body_points )
{
	deformer->template_generation += 1; // a batch this deformer's instance joins uploads it again
	const plGlApi* api = &deformer->api;
	plGlVec4* rows = deformer->staging;
	uint32_t n = deformer->vertex_count;
	plGlToVec4( rows, shaped_template, n, 1.0f );
	if ( deformer->point_count > 0 )
		plGlToVec4( rows + n, body_points, deformer->point_count, 1.0f );
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, deformer->bindings[PLEAT_GL_BINDING_SHAPED_TEMPLATE] );
	api->BufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)( plGlShapedRows( deformer ) * 16 ), rows );
}

// Rewrites the two body-contact fields of the params buffer (the rest never changes).
static void plUploadContactParams( plGlDeformer* deformer )
{
	const plGlApi* api = &deformer->api;
	float offset = deformer->body_contact_offset_m;
	api->BindBuffer( GL_UNIFORM_BUFFER, deformer->params_buffer );
	api->BufferSubData( GL_UNIFORM_BUFFER, (GLintptr)offsetof( plGlDeformParams, body_contact_offset_m ), 4, &offset );
}

// [D][N][3] → [D][N] vec4 (fp32) or plGlHalf4 (fp16), one blend shape at a time through the staging block. int8
// shapes go up as fp32, each element (float)q · scale (plShapeValue), and the shader reads fp32 or fp16: the GPU's
// w · (q · s) against the CPU's (w · s) · q, a rounding apart.
static void plUploadBlendShapes( plGlDeformer* deformer, const plBlendShapes* blend_shapes )
{
	const plGlApi* api = &deformer->api;
	size_t n = deformer->vertex_count;
	int fp16 = blend_shapes->type == PLEAT_SHAPES_F16;
	size_t row_bytes = fp16 ? sizeof( plGlHalf4 ) : sizeof( plGlVec4 );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_BLEND_SHAPES, row_bytes * n * deformer->blend_count, NULL,
					GL_STATIC_DRAW );
	for ( uint32_t j = 0; j < deformer->blend_count; ++j )
	{
		if ( fp16 )
		{
			const uint16_t* shape = (const uint16_t*)blend_shapes->data + (size_t)j * n * 3;
			plGlHalf4* rows = deformer->staging;
			for ( size_t i = 0; i < n; ++i )
				rows[i] = ( plGlHalf4 ){ shape[3 * i], shape[3 * i + 1], shape[3 * i + 2], 0 };
		}
		else
		{
			size_t first = (size_t)j * n * 3;
			plGlVec4* rows = deformer->staging;
			for ( size_t i = 0; i < n; ++i )
				rows[i] = ( plGlVec4 ){ plShapeValue( blend_shapes, j, first + 3 * i ),
										plShapeValue( blend_shapes, j, first + 3 * i + 1 ),
										plShapeValue( blend_shapes, j, first + 3 * i + 2 ), 0.0f };
		}
		api->BufferSubData( GL_SHADER_STORAGE_BUFFER, (GLintptr)( row_bytes * n * j ), (GLsizeiptr)( row_bytes * n ),
							deformer->staging );
	}
}

static plResult plCheckHostBuffer( const plGlApi* api, GLuint buffer, uint32_t vertex_count )
{
	if ( !api->IsBuffer( buffer ) )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	GLint64 size = 0;
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, buffer );
	api->GetBufferParameteri64v( GL_SHADER_STORAGE_BUFFER, GL_BUFFER_SIZE, &size );
	return size >= (GLint64)vertex_count * 16 ? PLEAT_RESULT_OK : PLEAT_RESULT_BUFFER_TOO_SMALL;
}

// Everything of Create that needs GL; runs between plBegin and plEnd.
static plResult plCreateGlObjects( plGlDeformer* deformer, const plGlDeformerDesc* desc )
{
	const plGlApi* api = &deformer->api;
	if ( plGlApi_CurrentVersion( api ) < 43 )
		return PLEAT_RESULT_GL_UNAVAILABLE;
	// A host context may have errors pending from the engine; they are not ours to report.
	plGlCheckErrors( api );

	plResult result = PLEAT_RESULT_OK;
	if ( desc->host_position_buffer != 0 )
		result = plCheckHostBuffer( api, desc->host_position_buffer, desc->vertex_count );
	if ( result == PLEAT_RESULT_OK && desc->host_normal_buffer != 0 )
		result = plCheckHostBuffer( api, desc->host_normal_buffer, desc->vertex_count );
	if ( result != PLEAT_RESULT_OK )
		return result;

	plGlShared* shared = deformer->shared;
	int sharing = desc->share != NULL;
	uint32_t Ka = deformer->anchor_influence_count, R = deformer->point_ring_count;
	if ( !sharing )
	{
		shared->programs[PLEAT_GL_PROGRAM_BLEND_SHAPES] = plGlCompileProgram(
			api, plGlShaderSource_blend_shapes,
			desc->blend_shapes.type == PLEAT_SHAPES_F16 ? "#define PLEAT_BLEND_FP16 1\n"
														: "#define PLEAT_BLEND_FP16 0\n" );
		shared->programs[PLEAT_GL_PROGRAM_SKINNING] = plGlCompileProgram( api, plGlShaderSource_skinning, "" );
		shared->programs[PLEAT_GL_PROGRAM_FACE_NORMALS] = plGlCompileProgram( api, plGlShaderSource_face_normals, "" );
		shared->programs[PLEAT_GL_PROGRAM_NORMALS_GATHER] = plGlCompileProgram( api, plGlShaderSource_normals_gather, "" );
		if ( Ka > 0 )
		{
			shared->programs[PLEAT_GL_PROGRAM_BODY_POINTS] =
				plGlCompileProgram( api, plGlShaderSource_body_contact, PLEAT_GL_POSE_POINTS_DEFINES );
			shared->programs[PLEAT_GL_PROGRAM_BODY_CONTACT] =
				plGlCompileProgram( api, plGlShaderSource_body_contact, PLEAT_GL_CONTACT_DEFINES );
		}
		if ( R > 0 )
			shared->programs[PLEAT_GL_PROGRAM_BODY_POINT_NORMALS] =
				plGlCompileProgram( api, plGlShaderSource_body_contact, PLEAT_GL_POINT_NORMALS_DEFINES );
		for ( int p = 0; p < PLEAT_GL_PROGRAM_COUNT; ++p )
		{
			int needed = 1;
			if ( p == PLEAT_GL_PROGRAM_BODY_POINTS || p == PLEAT_GL_PROGRAM_BODY_CONTACT )
				needed = Ka > 0;
			if ( p == PLEAT_GL_PROGRAM_BODY_POINT_NORMALS )
				needed = R > 0;
			if ( shared->programs[p] == 0 && needed )
				return PLEAT_RESULT_GL_ERROR;
		}
	}
	memcpy( deformer->programs, shared->programs, sizeof( deformer->programs ) );

	size_t n = desc->vertex_count, P = deformer->point_count, C = deformer->candidate_count;
	plGlDeformParams params = { desc->vertex_count,
								desc->blend_count,
								desc->influence_count,
								desc->joint_count,
								desc->face_count,
								Ka,
								deformer->body_contact_offset_m,
								(uint32_t)plGlShapedRows( deformer ),
								deformer->point_count,
								deformer->candidate_count,
								R,
								desc->body_anchor_candidates != NULL ? 1u : 0u };
	api->GenBuffers( 1, &deformer->params_buffer );
	api->BindBuffer( GL_UNIFORM_BUFFER, deformer->params_buffer );
	api->BufferData( GL_UNIFORM_BUFFER, sizeof( params ), &params, GL_STATIC_DRAW );

	// The deformer's own buffers: the template of its β, its weights, T_def, matrices, outputs and posed body points.
	plCreateBuffer( deformer, PLEAT_GL_BINDING_SHAPED_TEMPLATE, plGlShapedRows( deformer ) * 16, NULL, GL_DYNAMIC_DRAW );
	plUploadShapedTemplate( deformer, desc->shaped_template, desc->body_anchors );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_BLEND_WEIGHTS, (size_t)desc->blend_count * 4, NULL, GL_STREAM_DRAW );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_DEFORMED, n * 16, NULL, GL_DYNAMIC_COPY );
	// [J][3][4] row-major floats are already three vec4 rows per joint.
	plCreateBuffer( deformer, PLEAT_GL_BINDING_SKIN_MATRICES, (size_t)desc->joint_count * 48, NULL, GL_STREAM_DRAW );
	if ( desc->host_position_buffer != 0 )
		deformer->bindings[PLEAT_GL_BINDING_POSITIONS] = desc->host_position_buffer;
	else
		plCreateBuffer( deformer, PLEAT_GL_BINDING_POSITIONS, n * 16, NULL, GL_DYNAMIC_COPY );
	if ( desc->host_normal_buffer != 0 )
		deformer->bindings[PLEAT_GL_BINDING_NORMALS] = desc->host_normal_buffer;
	else
		plCreateBuffer( deformer, PLEAT_GL_BINDING_NORMALS, n * 16, NULL, GL_DYNAMIC_COPY );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_FACE_NORMALS, (size_t)desc->face_count * 16, NULL, GL_DYNAMIC_COPY );
	// (Without body points nothing reads it, but every binding point gets a buffer, as the shaders' others do.)
	plCreateBuffer( deformer, PLEAT_GL_BINDING_POSED_POINTS, Ka > 0 ? P * 32 : 16, NULL, GL_DYNAMIC_COPY );
	if ( sharing )
	{
		for ( int b = 0; b < PLEAT_GL_BINDING_COUNT; ++b )
		{
			if ( plGlBindingIsStatic( (plGlBinding)b ) )
				deformer->bindings[b] = shared->buffers[b];
		}
		if ( desc->networks != NULL )
			deformer->networks = shared->networks;
		return plGlCheckErrors( api );
	}

	// The static buffers, made once for the deformers that share them: the mesh, its skinning and body points.
	plUploadBlendShapes( deformer, &desc->blend_shapes );
	uint32_t* skin_indices = deformer->staging; // u16 → the shader's uint
	for ( size_t e = 0; e < n * desc->influence_count; ++e )
		skin_indices[e] = desc->skin_indices[e];
	plCreateBuffer( deformer, PLEAT_GL_BINDING_SKIN_INDICES, n * desc->influence_count * 4, skin_indices,
					GL_STATIC_DRAW );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_SKIN_WEIGHTS, n * desc->influence_count * 4, desc->skin_weights,
					GL_STATIC_DRAW );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_FACES, (size_t)desc->face_count * 12, desc->faces, GL_STATIC_DRAW );
	plCreateBuffer( deformer, PLEAT_GL_BINDING_ADJACENCY_OFFSETS, ( n + 1 ) * 4, desc->adjacency_offsets,
					GL_STATIC_DRAW );
	// At least one element: a zero-sized buffer cannot be bound.
	size_t adjacency_count = desc->adjacency_offsets[n] > 0 ? desc->adjacency_offsets[n] : 1;
	plCreateBuffer( deformer, PLEAT_GL_BINDING_ADJACENCY_FACES, adjacency_count * 4, desc->adjacency_faces,
					GL_STATIC_DRAW );
	if ( Ka > 0 )
	{
		plGlVec4* rows = deformer->staging;
		plGlToVec4( rows, desc->body_anchor_normals, deformer->point_count, 0.0f );
		plCreateBuffer( deformer, PLEAT_GL_BINDING_ANCHOR_NORMALS, P * 16, rows, GL_STATIC_DRAW );
		uint32_t* indices = deformer->staging; // u16 → the shader's uint
		for ( size_t e = 0; e < P * Ka; ++e )
			indices[e] = desc->body_anchor_skin_indices[e];
		plCreateBuffer( deformer, PLEAT_GL_BINDING_ANCHOR_SKIN_INDICES, P * Ka * 4, indices, GL_STATIC_DRAW );
		plCreateBuffer( deformer, PLEAT_GL_BINDING_ANCHOR_SKIN_WEIGHTS, P * Ka * 4, desc->body_anchor_skin_weights,
						GL_STATIC_DRAW );
		// u16 → uint, PLEAT_NO_CONTACT_CANDIDATE staying >= P. A 1.1 asset (no table) gets the identity with C = 1, so
		// the push has one loop for both, as plBodyContact_Scalar reads candidates[v] = v there.
		uint32_t* candidates = deformer->staging;
		for ( size_t e = 0; e < n * C; ++e )
			candidates[e] = desc->body_anchor_candidates != NULL ? desc->body_anchor_candidates[e] : (uint32_t)e;
		plCreateBuffer( deformer, PLEAT_GL_BINDING_CONTACT_CANDIDATES, n * C * 4, candidates, GL_STATIC_DRAW );
	}
	else
	{
		// Nothing reads them, but every binding point gets a buffer, as the shaders' other buffers do.
		for ( int b = PLEAT_GL_BINDING_ANCHOR_NORMALS; b <= PLEAT_GL_BINDING_ANCHOR_SKIN_WEIGHTS; ++b )
			plCreateBuffer( deformer, (plGlBinding)b, 16, NULL, GL_STATIC_DRAW );
		plCreateBuffer( deformer, PLEAT_GL_BINDING_CONTACT_CANDIDATES, 16, NULL, GL_STATIC_DRAW );
	}
	if ( R > 0 )
	{
		uint32_t* rings = deformer->staging; // u16 → uint, the empty entries (0xFFFF) staying >= P
		for ( size_t e = 0; e < P * R; ++e )
			rings[e] = desc->body_anchor_ring[e];
		plCreateBuffer( deformer, PLEAT_GL_BINDING_POINT_RINGS, P * R * 4, rings, GL_STATIC_DRAW );
	}
	else
		plCreateBuffer( deformer, PLEAT_GL_BINDING_POINT_RINGS, 16, NULL, GL_STATIC_DRAW ); // read by nothing
	// Read by batches only (plGlDeformer_RunBatch binds its own); a single Run binds this placeholder.
	plCreateBuffer( deformer, PLEAT_GL_BINDING_BATCH_CONTACT, 16, NULL, GL_STATIC_DRAW );
	result = plGlCheckErrors( api );
	if ( result == PLEAT_RESULT_OK && desc->networks != NULL )
	{
		result = plGlNetworks_Create( deformer, &shared->networks, desc->networks );
		deformer->networks = shared->networks;
	}
	return result;
}

// The deformer's own GL objects (the shared ones go with the last deformer: plReleaseShared).
static void plDeleteGlObjects( plGlDeformer* deformer )
{
	const plGlApi* api = &deformer->api;
	if ( deformer->params_buffer != 0 )
		api->DeleteBuffers( 1, &deformer->params_buffer );
	for ( int b = 0; b < PLEAT_GL_BINDING_COUNT; ++b )
	{
		if ( deformer->owned[b] != 0 )
			api->DeleteBuffers( 1, &deformer->owned[b] );
		if ( deformer->batch.buffers[b] != 0 )
			api->DeleteBuffers( 1, &deformer->batch.buffers[b] );
		deformer->batch.buffers[b] = 0;
	}
	if ( deformer->batch.points_program != 0 )
		api->DeleteProgram( deformer->batch.points_program );
	if ( deformer->batch.normals_program != 0 )
		api->DeleteProgram( deformer->batch.normals_program );
	if ( deformer->batch.contact_program != 0 )
		api->DeleteProgram( deformer->batch.contact_program );
	if ( deformer->batch.timer_queries[0] != 0 )
		api->DeleteQueries( 2, deformer->batch.timer_queries );
	deformer->batch.timer_queries[0] = deformer->batch.timer_queries[1] = 0;
	deformer->batch.points_program = 0;
	deformer->batch.normals_program = 0;
	deformer->batch.contact_program = 0;
	deformer->batch.capacity = 0;
	plGlNetworks_DeleteBatch( deformer );
}

// One deformer fewer on the shared block; the last one deletes its GL objects (its context must be usable: between
// plGlBegin and plGlEnd) and returns non-zero: the caller then frees the block and destroys its headless context.
static int plReleaseShared( plGlDeformer* deformer, int gl_usable )
{
	plGlShared* shared = deformer->shared;
	if ( atomic_fetch_sub_explicit( &shared->refcount, 1, memory_order_acq_rel ) != 1 )
		return 0;
	if ( gl_usable )
	{
		const plGlApi* api = &deformer->api;
		for ( int p = 0; p < PLEAT_GL_PROGRAM_COUNT; ++p )
		{
			if ( shared->programs[p] != 0 )
				api->DeleteProgram( shared->programs[p] );
		}
		for ( int b = 0; b < PLEAT_GL_BINDING_COUNT; ++b )
		{
			if ( shared->buffers[b] != 0 )
				api->DeleteBuffers( 1, &shared->buffers[b] );
		}
		plGlNetworks_DeleteStatic( api, &shared->networks );
	}
	return 1;
}

// Frees the deformer's memory and, when it held the last reference (last), the shared block and its context.
static void plFreeDeformer( plGlDeformer* deformer, int last )
{
	plAllocator allocator = deformer->allocator;
	if ( last && deformer->shared != NULL )
	{
		if ( deformer->shared->context != NULL )
			plGlContext_Destroy( deformer->shared->context );
		plFree( &allocator, deformer->shared, sizeof( plGlShared ) );
	}
	plFree( &allocator, deformer->staging, deformer->staging_bytes );
	plFree( &allocator, deformer->batch.template_keys, deformer->batch.template_keys_bytes );
	plFree( &allocator, deformer->batch.staging, deformer->batch.staging_bytes );
	plGlNetworks_FreeHost( deformer );
	plFree( &allocator, deformer, sizeof( *deformer ) );
}

static plResult plCreate( const plGlDeformerDesc* desc, const plAllocator* allocator, plGlHeadlessBackend backend,
						  plGlDeformer** out )
{
	if ( out == NULL )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	*out = NULL;
	if ( desc == NULL || allocator == NULL ||
		 ( desc->mode != PLEAT_GL_DEFORMER_HOST_CONTEXT && desc->mode != PLEAT_GL_DEFORMER_HEADLESS ) )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	plResult result = plValidateDesc( desc );
	if ( result != PLEAT_RESULT_OK )
		return result;
	const plGlDeformer* share = desc->share;
	if ( share != NULL && ( share->mode != desc->mode ||
							share->vertex_count != desc->vertex_count || share->face_count != desc->face_count ||
							share->blend_count != desc->blend_count || share->joint_count != desc->joint_count ||
							share->influence_count != desc->influence_count ||
							( share->networks.lp_count > 0 ) != ( desc->networks != NULL ) ||
							share->point_count != ( desc->body_anchors != NULL ? desc->body_point_count : 0u ) ||
							share->candidate_count !=
								( desc->body_anchors != NULL ? desc->body_anchor_candidate_count : 0u ) ||
							share->point_ring_count != ( desc->body_anchors != NULL ? desc->body_anchor_ring_count : 0u ) ) )
		return PLEAT_RESULT_INVALID_ARGUMENT; // (the instance checks it is the same asset; this keeps the shapes honest)

	plGlDeformer* deformer = plAllocZeroed( allocator, sizeof( *deformer ), 16 );
	if ( deformer == NULL )
		return PLEAT_RESULT_OUT_OF_MEMORY;
	deformer->allocator = *allocator;
	if ( share != NULL )
	{
		deformer->shared = share->shared;
		atomic_fetch_add_explicit( &deformer->shared->refcount, 1, memory_order_relaxed );
	}
	else
	{
		deformer->shared = plAllocZeroed( allocator, sizeof( plGlShared ), 16 );
		if ( deformer->shared == NULL )
		{
			plFree( allocator, deformer, sizeof( *deformer ) );
			return PLEAT_RESULT_OUT_OF_MEMORY;
		}
		atomic_store_explicit( &deformer->shared->refcount, 1, memory_order_relaxed );
	}
	deformer->mode = desc->mode;
	deformer->vertex_count = desc->vertex_count;
	deformer->face_count = desc->face_count;
	deformer->blend_count = desc->blend_count;
	deformer->influence_count = desc->influence_count;
	deformer->joint_count = desc->joint_count;
	deformer->serial = atomic_fetch_add_explicit( &s_plGlDeformerSerial, 1, memory_order_relaxed ) + 1;
	// Without networks the deformer touches (and saves) bindings 0..19 only, as before the networks came.
	deformer->binding_count = desc->networks != NULL ? PLEAT_GL_BINDING_COUNT : PLEAT_GL_BINDING_NETWORK_WEIGHTS;
	int points = desc->body_anchors != NULL;
	deformer->anchor_influence_count = points ? desc->body_anchor_influence_count : 0;
	deformer->point_count = points ? desc->body_point_count : 0;
	deformer->candidate_count = points ? desc->body_anchor_candidate_count : 0;
	deformer->point_ring_count = points ? desc->body_anchor_ring_count : 0;
	deformer->body_contact = points;
	deformer->body_contact_offset_m = PLEAT_BODY_CONTACT_DEFAULT_OFFSET_M;
	// Staging holds the largest upload: N + P vec4 rows (template + body points; also the N rows of a blend shape or a
	// read-back and the P of the point normals), or the uints of [N][K], [P][Ka], [N][C] or [P][R].
	size_t rows = plGlShapedRows( deformer ) * 16;
	size_t skin = (size_t)desc->vertex_count * 4 * desc->influence_count;
	size_t point_skin = (size_t)deformer->point_count * 4 * deformer->anchor_influence_count;
	size_t candidates = (size_t)desc->vertex_count * 4 * deformer->candidate_count;
	size_t rings = (size_t)deformer->point_count * 4 * deformer->point_ring_count;
	deformer->staging_bytes = rows > skin ? rows : skin;
	deformer->staging_bytes = deformer->staging_bytes > point_skin ? deformer->staging_bytes : point_skin;
	deformer->staging_bytes = deformer->staging_bytes > candidates ? deformer->staging_bytes : candidates;
	deformer->staging_bytes = deformer->staging_bytes > rings ? deformer->staging_bytes : rings;
	deformer->staging = plAlloc( allocator, deformer->staging_bytes, 64 );
	if ( deformer->staging == NULL )
	{
		plFreeDeformer( deformer, plReleaseShared( deformer, 0 ) );
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}

	if ( desc->mode == PLEAT_GL_DEFORMER_HEADLESS && share != NULL )
	{
		// The sharer's context: made current by whichever of them is called.
		deformer->context = share->context;
		deformer->api = share->api;
		if ( desc->report != NULL && desc->report_size > 0 )
			snprintf( desc->report, desc->report_size, "sharing another instance's headless context" );
	}
	else if ( desc->mode == PLEAT_GL_DEFORMER_HEADLESS )
	{
		result = plGlContext_Create( backend, allocator, &deformer->shared->context, desc->report, desc->report_size );
		if ( result != PLEAT_RESULT_OK )
		{
			plFreeDeformer( deformer, plReleaseShared( deformer, 0 ) );
			return result;
		}
		deformer->context = deformer->shared->context;
		deformer->api = *plGlContext_Api( deformer->context );
	}
	else
	{
		plGlApi_LoadEpoxy( &deformer->api );
		// Without a current context epoxy cannot resolve anything beyond GL 1.x; glGetString answers NULL then.
		if ( !plHostContextIsCurrent( &deformer->api ) )
		{
			plFreeDeformer( deformer, plReleaseShared( deformer, 0 ) );
			return PLEAT_RESULT_GL_UNAVAILABLE;
		}
	}

	int last = 0;
	result = plGlBegin( deformer );
	if ( result == PLEAT_RESULT_OK )
	{
		result = plCreateGlObjects( deformer, desc );
		if ( result != PLEAT_RESULT_OK )
		{
			plDeleteGlObjects( deformer );
			last = plReleaseShared( deformer, 1 );
			plGlCheckErrors( &deformer->api );
		}
		plGlEnd( deformer );
	}
	else
		last = plReleaseShared( deformer, 0 );
	if ( result != PLEAT_RESULT_OK )
	{
		plFreeDeformer( deformer, last );
		return result;
	}
	*out = deformer;
	return PLEAT_RESULT_OK;
}

int plGlDeformer_HasNetworks( const plGlDeformer* deformer )
{
	return deformer != NULL && deformer->networks.lp_count > 0;
}

plResult plGlDeformer_Create( const plGlDeformerDesc* desc, const plAllocator* allocator, plGlDeformer** out )
{
	return plCreate( desc, allocator, PLEAT_GL_HEADLESS_AUTO, out );
}

plResult plGlDeformer_CreateHeadless( const plGlDeformerDesc* desc, const plAllocator* allocator,
									  plGlHeadlessBackend backend, plGlDeformer** out )
{
	if ( desc == NULL || desc->mode != PLEAT_GL_DEFORMER_HEADLESS )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	return plCreate( desc, allocator, backend, out );
}

plGlHeadlessBackend plGlDeformer_Backend( const plGlDeformer* deformer )
{
	return deformer->context != NULL ? plGlContext_Backend( deformer->context ) : PLEAT_GL_HEADLESS_AUTO;
}

plGlHeadlessPlatform plGlDeformer_Platform( const plGlDeformer* deformer )
{
	return deformer->context != NULL ? plGlContext_Platform( deformer->context ) : PLEAT_GL_PLATFORM_NONE;
}

plResult plGlDeformer_SetShapedTemplate( plGlDeformer* deformer, const float* shaped_template, const float* body_anchors )
{
	if ( deformer == NULL || shaped_template == NULL || ( deformer->anchor_influence_count > 0 && body_anchors == NULL ) )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	plResult result = plGlBegin( deformer );
	if ( result != PLEAT_RESULT_OK )
		return result;
	plGlCheckErrors( &deformer->api ); // an error the engine left pending is not ours to report
	plUploadShapedTemplate( deformer, shaped_template, body_anchors );
	result = plGlCheckErrors( &deformer->api );
	plGlEnd( deformer );
	return result;
}

// Reads one vec4 [N] buffer back and drops w: out is [N][3].
static void plReadBack( plGlDeformer* deformer, GLuint buffer, float* out )
{
	const plGlApi* api = &deformer->api;
	plGlVec4* rows = deformer->staging;
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, buffer );
	api->GetBufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)deformer->vertex_count * 16, rows );
	for ( uint32_t i = 0; i < deformer->vertex_count; ++i )
	{
		out[3 * i] = rows[i].x;
		out[3 * i + 1] = rows[i].y;
		out[3 * i + 2] = rows[i].z;
	}
}

plResult plGlDeformer_SetBodyContact( plGlDeformer* deformer, int enabled, float offset_m )
{
	if ( deformer == NULL || !( offset_m >= 0.0f && offset_m <= PLEAT_BODY_CONTACT_MAX_OFFSET_M ) )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	int active = enabled != 0 && deformer->anchor_influence_count > 0;
	if ( offset_m == deformer->body_contact_offset_m || deformer->anchor_influence_count == 0 )
	{
		deformer->body_contact = active;
		return PLEAT_RESULT_OK;
	}
	plResult result = plGlBegin( deformer );
	if ( result != PLEAT_RESULT_OK )
		return result;
	plGlCheckErrors( &deformer->api ); // an error the engine left pending is not ours to report
	float previous = deformer->body_contact_offset_m;
	deformer->body_contact_offset_m = offset_m;
	plUploadContactParams( deformer );
	result = plGlCheckErrors( &deformer->api );
	if ( result == PLEAT_RESULT_OK )
		deformer->body_contact = active;
	else
		deformer->body_contact_offset_m = previous; // GL ignored the upload: nothing changed
	plGlEnd( deformer );
	return result;
}

// The shaders in order, one dispatch each with `instances` rows of workgroups in y (1 for a single Run) and a storage
// barrier between stages: blend_shapes → skinning → (points_program over the P body points, normals_program over them
// where the asset has rings (0 = none), then contact_program over the vertices; 0 = no contact) → face_normals →
// normals_gather. The buffers and params are bound by the caller.
void plGlRunShaders( const plGlDeformer* deformer, GLuint points_program, GLuint normals_program,
						  GLuint contact_program, uint32_t instances )
{
	const plGlApi* api = &deformer->api;
	GLuint groups = ( deformer->vertex_count + PLEAT_GL_WORKGROUP_SIZE - 1 ) / PLEAT_GL_WORKGROUP_SIZE;
	GLuint face_groups = ( deformer->face_count + PLEAT_GL_WORKGROUP_SIZE - 1 ) / PLEAT_GL_WORKGROUP_SIZE;
	GLuint point_groups = ( deformer->point_count + PLEAT_GL_WORKGROUP_SIZE - 1 ) / PLEAT_GL_WORKGROUP_SIZE;
	api->UseProgram( deformer->programs[PLEAT_GL_PROGRAM_BLEND_SHAPES] );
	plGlDispatch( api, groups, instances );
	api->MemoryBarrier( GL_SHADER_STORAGE_BARRIER_BIT );
	// Posing the body points reads nothing skinning writes, so no barrier between the two; the one after posing also
	// covers the skinned positions, which the push reads.
	api->UseProgram( deformer->programs[PLEAT_GL_PROGRAM_SKINNING] );
	plGlDispatch( api, groups, instances );
	if ( contact_program != 0 )
	{
		api->UseProgram( points_program );
		plGlDispatch( api, point_groups, instances );
		api->MemoryBarrier( GL_SHADER_STORAGE_BARRIER_BIT );
		if ( normals_program != 0 )
		{
			// A point's normal reads the posed positions of the points in its ring.
			api->UseProgram( normals_program );
			plGlDispatch( api, point_groups, instances );
			api->MemoryBarrier( GL_SHADER_STORAGE_BARRIER_BIT );
		}
		// Every vertex reads the posed points of its candidates, which other invocations wrote.
		api->UseProgram( contact_program );
		plGlDispatch( api, groups, instances );
	}
	api->MemoryBarrier( GL_SHADER_STORAGE_BARRIER_BIT );
	api->UseProgram( deformer->programs[PLEAT_GL_PROGRAM_FACE_NORMALS] );
	plGlDispatch( api, face_groups, instances );
	api->MemoryBarrier( GL_SHADER_STORAGE_BARRIER_BIT );
	api->UseProgram( deformer->programs[PLEAT_GL_PROGRAM_NORMALS_GATHER] );
	plGlDispatch( api, groups, instances );
	// Whatever reads the outputs next: our read-back, or the engine's vertex fetch / shaders from its buffers.
	api->MemoryBarrier( GL_BUFFER_UPDATE_BARRIER_BIT | GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT |
						GL_SHADER_STORAGE_BARRIER_BIT );
}

plResult plGlDeformer_Run( plGlDeformer* deformer, const float* blend_weights, const float* skin_matrices,
						   float* positions, float* normals )
{
	if ( deformer == NULL || blend_weights == NULL || skin_matrices == NULL )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	plResult result = plGlBegin( deformer );
	if ( result != PLEAT_RESULT_OK )
		return result;
	const plGlApi* api = &deformer->api;
	plGlCheckErrors( api ); // an error the engine left pending is not ours to report

	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, deformer->bindings[PLEAT_GL_BINDING_BLEND_WEIGHTS] );
	api->BufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)deformer->blend_count * 4, blend_weights );
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, deformer->bindings[PLEAT_GL_BINDING_SKIN_MATRICES] );
	api->BufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)deformer->joint_count * 48, skin_matrices );

	api->BindBufferBase( GL_UNIFORM_BUFFER, PLEAT_GL_PARAMS_BINDING, deformer->params_buffer );
	for ( GLuint b = 0; b < PLEAT_GL_BINDING_NETWORK_WEIGHTS; ++b )
		api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, b, deformer->bindings[b] );

	if ( deformer->body_contact )
		plGlRunShaders( deformer, deformer->programs[PLEAT_GL_PROGRAM_BODY_POINTS],
					  deformer->programs[PLEAT_GL_PROGRAM_BODY_POINT_NORMALS],
					  deformer->programs[PLEAT_GL_PROGRAM_BODY_CONTACT], 1 );
	else
		plGlRunShaders( deformer, 0, 0, 0, 1 );

	if ( positions != NULL )
		plReadBack( deformer, deformer->bindings[PLEAT_GL_BINDING_POSITIONS], positions );
	if ( normals != NULL )
		plReadBack( deformer, deformer->bindings[PLEAT_GL_BINDING_NORMALS], normals );
	result = plGlCheckErrors( api );
	plGlEnd( deformer );
	return result;
}

void plGlDeformer_Destroy( plGlDeformer* deformer )
{
	if ( deformer == NULL )
		return;
	int last;
	if ( plGlBegin( deformer ) == PLEAT_RESULT_OK )
	{
		plDeleteGlObjects( deformer );
		last = plReleaseShared( deformer, 1 );
		plGlEnd( deformer );
	}
	else
		last = plReleaseShared( deformer, 0 ); // no context: GL objects cannot be deleted (as before sharing)
	plFreeDeformer( deformer, last );
}
