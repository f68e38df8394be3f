// The networks on the GPU (PLEAT_MLP_BACKEND_GPU): f_LP → latent guard → f_dec for the members of a batch that run
// them, before the blend (gl_batch.c). One dispatch of mlp_layer.comp per layer for the whole batch and one of
// latent_guard.comp; the decoder's last layer writes each member's blend weights into its slot of the batch's weights
// buffer, where blend_shapes.comp reads them, so a crowd's step is one upload of X_c and one set of dispatches with no
// network on the CPU. What the CPU still needs (Z_t+1 for the next X_c, w for the held weights, the finite checks)
// comes back in one small read-back after the deformation (docs/gpu.md "Networks on the GPU").
#include "gl_deformer_data.h"
#include "gl_shaders.h"
#include <string.h>

// Members per workgroup row of mlp_layer.comp (its PLEAT_LAYER_MEMBERS).
#define PLEAT_GL_LAYER_MEMBERS 4u

static int plLayerOnGpu( const plLayer* l )
{
	return l->weight != NULL && l->bias != NULL && !l->weight_int8 && l->in_count > 0 && l->out_count > 0 &&
		   l->block_count <= PLEAT_MAX_LAYER_BLOCKS && (uint64_t)l->in_count * l->out_count * 4u <= 0x7fffffffu;
}

plResult plGlNetworks_Validate( const plGlNetworksDesc* d, uint32_t blend_count )
{
	if ( d->lp == NULL || d->dec == NULL || d->lp_layer_count == 0 || d->lp_layer_count > PLEAT_MAX_LAYERS ||
		 d->dec_layer_count == 0 || d->dec_layer_count > PLEAT_MAX_LAYERS || d->z_mean == NULL || d->z_std == NULL ||
		 d->z_min == NULL || d->z_max == NULL )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	const uint32_t activations[2] = { d->lp_activation, d->dec_activation };
	for ( int n = 0; n < 2; ++n )
	{
		if ( activations[n] != PLEAT_ACTIVATION_RELU && activations[n] != PLEAT_ACTIVATION_SILU )
			return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	for ( uint32_t i = 0; i < d->lp_layer_count + d->dec_layer_count; ++i )
	{
		int lp = i < d->lp_layer_count;
		const plLayer* l = lp ? &d->lp[i] : &d->dec[i - d->lp_layer_count];
		if ( l->weight_int8 )
			return PLEAT_RESULT_BACKEND_UNAVAILABLE; // int8 networks run on the CPU's integer kernels only
		if ( !plLayerOnGpu( l ) )
			return PLEAT_RESULT_INVALID_ARGUMENT;
		// Each layer reads its predecessor's width; the decoder reads f_LP's output, L.
		const plLayer* before = NULL;
		if ( i > 0 )
			before = i - 1 < d->lp_layer_count ? &d->lp[i - 1] : &d->dec[i - 1 - d->lp_layer_count];
		if ( before != NULL && before->out_count != l->in_count )
			return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	return d->dec[d->dec_layer_count - 1].out_count == blend_count ? PLEAT_RESULT_OK : PLEAT_RESULT_INVALID_ARGUMENT;
}

// A network buffer: at least 16 bytes (a zero-sized buffer cannot be bound).
static GLuint plNetworkBuffer( const plGlApi* api, size_t bytes, const void* data, GLenum usage )
{
	return plGlNewStorageBuffer( api, bytes > 0 ? bytes : 16, data, usage );
}

// W [out][in] (fp32 or fp16) → [in][out] float bits, or [in][(out + 1) / 2] half pairs (row r in the low half of
// word r / 2 when r is even), through staging.
static size_t plTransposeWeights( const plLayer* l, uint32_t* staging )
{
	uint32_t in = l->in_count, out = l->out_count;
	if ( l->weight_fp16 )
	{
		const uint16_t* w = (const uint16_t*)l->weight;
		uint32_t words = ( out + 1u ) / 2u;
		for ( uint32_t c = 0; c < in; ++c )
		{
			for ( uint32_t k = 0; k < words; ++k )
			{
				uint32_t r = 2u * k;
				uint32_t lo = w[(size_t)r * in + c];
				uint32_t hi = r + 1u < out ? w[(size_t)( r + 1u ) * in + c] : 0u;
				staging[(size_t)c * words + k] = lo | ( hi << 16 );
			}
		}
		return (size_t)in * words * 4u;
	}
	const float* w = (const float*)l->weight;
	for ( uint32_t c = 0; c < in; ++c )
	{
		for ( uint32_t r = 0; r < out; ++r )
			memcpy( &staging[(size_t)c * out + r], &w[(size_t)r * in + c], 4 );
	}
	return (size_t)in * out * 4u;
}

static plGlNetworkLayer plLayerParams( const plLayer* l, uint32_t activation, int by_slot )
{
	plGlNetworkLayer block;
	memset( &block, 0, sizeof( block ) );
	block.in_count = l->in_count;
	block.out_count = l->out_count;
	block.activation = activation;
	block.weight_fp16 = l->weight_fp16 ? 1u : 0u;
	block.output_by_slot = by_slot ? 1u : 0u;
	block.block_count = l->block_count;
	for ( uint32_t b = 0; b < l->block_count; ++b )
	{
		block.blocks[b][0] = l->blocks[b].row_begin;
		block.blocks[b][1] = l->blocks[b].row_end;
		block.blocks[b][2] = l->blocks[b].col_begin;
		block.blocks[b][3] = l->blocks[b].col_end;
	}
	return block;
}

plResult plGlNetworks_Create( plGlDeformer* deformer, plGlNetworks* nets, const plGlNetworksDesc* d )
{
	const plGlApi* api = &deformer->api;
	GLint bindings = 0;
	api->GetIntegerv( GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS, &bindings );
	if ( bindings < PLEAT_GL_BINDING_COUNT )
		return PLEAT_RESULT_GL_UNAVAILABLE; // the networks' buffers sit at bindings 20..27
	nets->layer_program = plGlCompileProgram( api, plGlShaderSource_mlp_layer, "" );
	nets->guard_program = plGlCompileProgram( api, plGlShaderSource_latent_guard, "" );
	if ( nets->layer_program == 0 || nets->guard_program == 0 )
		return PLEAT_RESULT_GL_ERROR;

	size_t largest = 0;
	for ( uint32_t i = 0; i < d->lp_layer_count + d->dec_layer_count; ++i )
	{
		const plLayer* l = i < d->lp_layer_count ? &d->lp[i] : &d->dec[i - d->lp_layer_count];
		size_t bytes = (size_t)l->in_count * l->out_count * 4u;
		largest = bytes > largest ? bytes : largest;
	}
	uint32_t L = d->lp[d->lp_layer_count - 1].out_count;
	largest = largest > (size_t)L * 16u ? largest : (size_t)L * 16u;
	uint32_t* staging = plAlloc( &deformer->allocator, largest, 64 );
	if ( staging == NULL )
		return PLEAT_RESULT_OUT_OF_MEMORY;
	nets->lp_count = d->lp_layer_count;
	nets->dec_count = d->dec_layer_count;
	nets->input_count = d->lp[0].in_count;
	nets->latent_count = L;
	for ( uint32_t i = 0; i < d->lp_layer_count + d->dec_layer_count; ++i )
	{
		int lp = i < d->lp_layer_count;
		uint32_t k = lp ? i : i - d->lp_layer_count;
		const plLayer* l = lp ? &d->lp[k] : &d->dec[k];
		int last = k + 1 == ( lp ? d->lp_layer_count : d->dec_layer_count );
		uint32_t activation = last ? 0u : ( lp ? d->lp_activation : d->dec_activation );
		if ( !last && l->out_count > nets->widest )
			nets->widest = l->out_count;
		plGlNetworkLayerBuffers* g = &nets->layers[i];
		g->in_count = l->in_count;
		g->out_count = l->out_count;
		size_t bytes = plTransposeWeights( l, staging );
		g->weights = plNetworkBuffer( api, bytes, staging, GL_STATIC_DRAW );
		g->bias = plNetworkBuffer( api, (size_t)l->out_count * 4u, l->bias, GL_STATIC_DRAW );
		plGlNetworkLayer block = plLayerParams( l, activation, !lp && last );
		g->params = plNetworkBuffer( api, sizeof( block ), &block, GL_STATIC_DRAW );
	}
	plGlNetworkLayer guard;
	memset( &guard, 0, sizeof( guard ) );
	guard.in_count = L;
	guard.out_count = L;
	nets->guard_params = plNetworkBuffer( api, sizeof( guard ), &guard, GL_STATIC_DRAW );
	float* ranges = (float*)staging;
	for ( uint32_t i = 0; i < L; ++i )
	{
		ranges[4 * i] = d->z_mean[i];
		ranges[4 * i + 1] = d->z_std[i];
		ranges[4 * i + 2] = d->z_min[i];
		ranges[4 * i + 3] = d->z_max[i];
	}
	nets->latent_range = plNetworkBuffer( api, (size_t)L * 16u, ranges, GL_STATIC_DRAW );
	plFree( &deformer->allocator, staging, largest );
	return plGlCheckErrors( api );
}

static void plDeleteBuffer( const plGlApi* api, GLuint* buffer )
{
	if ( *buffer != 0 )
		api->DeleteBuffers( 1, buffer );
	*buffer = 0;
}

static void plDeleteBatchBuffers( plGlDeformer* deformer )
{
	const plGlApi* api = &deformer->api;
	plGlNetworks* nets = &deformer->networks;
	GLuint* buffers[7] = { &nets->input, &nets->ping, &nets->pong, &nets->y, &nets->z, &nets->members, &nets->finite };
	for ( int b = 0; b < 7; ++b )
		plDeleteBuffer( api, buffers[b] );
	nets->capacity = 0;
}

void plGlNetworks_DeleteStatic( const plGlApi* api, plGlNetworks* nets )
{
	for ( uint32_t i = 0; i < nets->lp_count + nets->dec_count; ++i )
	{
		plDeleteBuffer( api, &nets->layers[i].weights );
		plDeleteBuffer( api, &nets->layers[i].bias );
		plDeleteBuffer( api, &nets->layers[i].params );
	}
	plDeleteBuffer( api, &nets->guard_params );
	plDeleteBuffer( api, &nets->latent_range );
	if ( nets->layer_program != 0 )
		api->DeleteProgram( nets->layer_program );
	if ( nets->guard_program != 0 )
		api->DeleteProgram( nets->guard_program );
	nets->layer_program = 0;
	nets->guard_program = 0;
}

void plGlNetworks_DeleteBatch( plGlDeformer* deformer )
{
	plDeleteBatchBuffers( deformer );
}

void plGlNetworks_FreeHost( plGlDeformer* deformer )
{
	plGlNetworks* nets = &deformer->networks;
	plFree( &deformer->allocator, nets->staging, nets->staging_bytes );
	nets->staging = NULL;
	nets->staging_bytes = 0;
}

// The batch's network buffers for `capacity` members (the first batch, or a larger one than before).
static plResult plReserve( plGlDeformer* lead, uint32_t capacity )
{
	plGlNetworks* nets = &lead->networks;
	if ( capacity <= nets->capacity )
		return PLEAT_RESULT_OK;
	const plGlApi* api = &lead->api;
	plDeleteBatchBuffers( lead );
	plGlNetworks_FreeHost( lead );
	size_t c = capacity, in = nets->input_count, L = nets->latent_count;
	size_t widest = nets->widest > 0 ? nets->widest : 1;
	size_t rows = c * in * 4u, members = sizeof( plGlNetworkMembers ) + c * 4u;
	nets->staging_bytes = rows > members ? rows : members;
	size_t read_back = c * ( L > lead->blend_count ? L : lead->blend_count ) * 4u; // Z or w of every member
	nets->staging_bytes = nets->staging_bytes > read_back ? nets->staging_bytes : read_back;
	nets->staging = plAlloc( &lead->allocator, nets->staging_bytes, 64 );
	if ( nets->staging == NULL )
	{
		nets->staging_bytes = 0;
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	nets->input = plNetworkBuffer( api, rows, NULL, GL_STREAM_DRAW );
	nets->ping = plNetworkBuffer( api, c * widest * 4u, NULL, GL_DYNAMIC_COPY );
	nets->pong = plNetworkBuffer( api, c * widest * 4u, NULL, GL_DYNAMIC_COPY );
	nets->y = plNetworkBuffer( api, c * L * 4u, NULL, GL_DYNAMIC_COPY );
	nets->z = plNetworkBuffer( api, c * L * 4u, NULL, GL_DYNAMIC_READ );
	nets->members = plNetworkBuffer( api, members, NULL, GL_STREAM_DRAW );
	nets->finite = plNetworkBuffer( api, c * 4u, NULL, GL_DYNAMIC_READ );
	plResult result = plGlCheckErrors( api );
	if ( result == PLEAT_RESULT_OK )
		nets->capacity = capacity;
	return result;
}

// One layer for `ran` members: input → output (weights, bias, block at their bindings).
static void plRunLayer( const plGlApi* api, const plGlNetworkLayerBuffers* layer, GLuint input, GLuint output,
						uint32_t ran )
{
	api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, PLEAT_GL_BINDING_NETWORK_WEIGHTS, layer->weights );
	api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, PLEAT_GL_BINDING_NETWORK_BIAS, layer->bias );
	api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, PLEAT_GL_BINDING_NETWORK_LAYER, layer->params );
	api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, PLEAT_GL_BINDING_NETWORK_INPUT, input );
	api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, PLEAT_GL_BINDING_NETWORK_OUTPUT, output );
	plGlDispatch( api, ( layer->out_count + PLEAT_GL_WORKGROUP_SIZE - 1 ) / PLEAT_GL_WORKGROUP_SIZE,
				  ( ran + PLEAT_GL_LAYER_MEMBERS - 1 ) / PLEAT_GL_LAYER_MEMBERS );
	// The next layer (or the guard, or the blend) reads what this one wrote.
	api->MemoryBarrier( GL_SHADER_STORAGE_BARRIER_BIT );
}

plResult plGlNetworks_Run( plGlDeformer* lead, const plGlBatchMember* members, uint32_t count, uint32_t* out_ran )
{
	*out_ran = 0;
	plGlNetworks* nets = &lead->networks;
	if ( nets->lp_count == 0 )
		return PLEAT_RESULT_OK;
	uint32_t ran = 0;
	for ( uint32_t k = 0; k < count; ++k )
		ran += members[k].network_input != NULL;
	if ( ran == 0 )
		return PLEAT_RESULT_OK;
	plResult result = plReserve( lead, count );
	if ( result != PLEAT_RESULT_OK )
		return result;
	const plGlApi* api = &lead->api;

	// X_c of each network member, in member order; then the members block: their count and batch slots.
	float* rows = nets->staging;
	uint32_t m = 0;
	for ( uint32_t k = 0; k < count; ++k )
	{
		if ( members[k].network_input != NULL )
			memcpy( rows + (size_t)( m++ ) * nets->input_count, members[k].network_input, nets->input_count * 4u );
	}
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, nets->input );
	api->BufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)ran * nets->input_count * 4, rows );
	plGlNetworkMembers* head = nets->staging;
	memset( head, 0, sizeof( *head ) );
	head->member_count = ran;
	uint32_t* slots = (uint32_t*)( head + 1 );
	m = 0;
	for ( uint32_t k = 0; k < count; ++k )
	{
		if ( members[k].network_input != NULL )
			slots[m++] = k;
	}
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, nets->members );
	api->BufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)( sizeof( *head ) + ran * 4u ), head );
	api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, PLEAT_GL_BINDING_NETWORK_MEMBERS, nets->members );

	// f_LP: X_c → hidden layers in ping and pong → y.
	api->UseProgram( nets->layer_program );
	GLuint x = nets->input;
	for ( uint32_t i = 0; i < nets->lp_count; ++i )
	{
		GLuint y = i + 1 == nets->lp_count ? nets->y : ( ( i & 1u ) ? nets->pong : nets->ping );
		plRunLayer( api, &nets->layers[i], x, y, ran );
		x = y;
	}
	// The guard: y → Z and the finite flags.
	api->UseProgram( nets->guard_program );
	api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, PLEAT_GL_BINDING_NETWORK_LAYER, nets->guard_params );
	api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, PLEAT_GL_BINDING_NETWORK_INPUT, nets->y );
	api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, PLEAT_GL_BINDING_NETWORK_OUTPUT, nets->z );
	api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, PLEAT_GL_BINDING_LATENT_RANGE, nets->latent_range );
	api->BindBufferBase( GL_SHADER_STORAGE_BUFFER, PLEAT_GL_BINDING_NETWORK_FINITE, nets->finite );
	plGlDispatch( api, ( ran + PLEAT_GL_WORKGROUP_SIZE - 1 ) / PLEAT_GL_WORKGROUP_SIZE, 1 );
	api->MemoryBarrier( GL_SHADER_STORAGE_BARRIER_BIT );
	// f_dec: Z → hidden layers → each member's w at its slot of the batch's weights buffer.
	api->UseProgram( nets->layer_program );
	x = nets->z;
	for ( uint32_t i = 0; i < nets->dec_count; ++i )
	{
		int last = i + 1 == nets->dec_count;
		GLuint hidden = ( i & 1u ) ? nets->pong : nets->ping;
		GLuint y = last ? lead->batch.buffers[PLEAT_GL_BINDING_BLEND_WEIGHTS] : hidden;
		plRunLayer( api, &nets->layers[nets->lp_count + i], x, y, ran );
		x = y;
	}
	*out_ran = ran;
	return PLEAT_RESULT_OK;
}

void plGlNetworks_ReadBack( plGlDeformer* lead, const plGlBatchMember* members, uint32_t count )
{
	plGlNetworks* nets = &lead->networks;
	const plGlApi* api = &lead->api;
	uint32_t L = nets->latent_count, D = lead->blend_count;
	uint32_t ran = 0;
	for ( uint32_t k = 0; k < count; ++k )
		ran += members[k].network_input != NULL;
	float* latents = nets->staging; // [ran][L] fits: staging holds capacity · max(L, D) floats
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, nets->z );
	api->GetBufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)ran * L * 4, latents );
	uint32_t m = 0;
	for ( uint32_t k = 0; k < count; ++k )
	{
		if ( members[k].network_input != NULL )
			memcpy( members[k].latent_out, latents + (size_t)( m++ ) * L, L * 4u );
	}
	uint32_t* flags = nets->staging;
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, nets->finite );
	api->GetBufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)ran * 4, flags );
	m = 0;
	for ( uint32_t k = 0; k < count; ++k )
	{
		if ( members[k].network_input != NULL )
			*members[k].latent_finite_out = flags[m++] != 0u;
	}
	// Each network member's w from its slot (the held weights of the others are the caller's already).
	float* weights = nets->staging;
	api->BindBuffer( GL_SHADER_STORAGE_BUFFER, lead->batch.buffers[PLEAT_GL_BINDING_BLEND_WEIGHTS] );
	api->GetBufferSubData( GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)count * D * 4, weights );
	for ( uint32_t k = 0; k < count; ++k )
	{
		if ( members[k].network_input != NULL )
			memcpy( members[k].weights_out, weights + (size_t)k * D, D * 4u );
	}
}
