// A small writer for Pleat asset format v1.0 (docs/asset-format.md), for tests only.
#include "test_asset_builder.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "asset.h"
#include "jobs.h"
#include "kernels.h"

static uint32_t plTestRandom( uint32_t* state )
{
	// xorshift32: deterministic across platforms.
	uint32_t x = *state;
	x ^= x << 13;
	x ^= x >> 17;
	x ^= x << 5;
	*state = x;
	return x;
}

static float plTestUniform( uint32_t* state, float scale )
{
	return scale * ( (float)( plTestRandom( state ) >> 8 ) / 8388608.0f - 1.0f );
}

plTestAssetParams plTestAsset_DefaultParams( void )
{
	plTestAssetParams p;
	memset( &p, 0, sizeof( p ) );
	p.grid_x = 6;
	p.grid_y = 8;
	p.joint_count = 5;
	p.input_joint_count = 3;
	p.influence_count = 2;
	p.beta_count = 2;
	p.latent_count = 8;
	p.blend_count = 6;
	p.lp_hidden[0] = 16;
	p.lp_hidden[1] = 12;
	p.dec_hidden[0] = 10;
	p.activation = 1;
	p.weight_scale = 1.0f;
	p.blend_scale = 0.01f;
	p.seed = 12345;
	return p;
}

static float* plTestFloats( size_t count )
{
	return (float*)calloc( count > 0 ? count : 1, sizeof( float ) );
}

static void plTestMakeLayer( plTestLayer* layer, uint32_t in, uint32_t out, float scale, uint32_t* rng )
{
	layer->in_count = in;
	layer->out_count = out;
	layer->weight = plTestFloats( (size_t)in * out );
	layer->bias = plTestFloats( out );
	float s = scale / sqrtf( (float)in );
	for ( size_t i = 0; i < (size_t)in * out; ++i )
	{
		layer->weight[i] = plTestUniform( rng, s );
	}
	for ( uint32_t i = 0; i < out; ++i )
	{
		layer->bias[i] = plTestUniform( rng, 0.1f * scale );
	}
}

// A network: the hidden layers (widths up to 4, a 0 ends them) and the output layer, from in inputs. Returns the
// layer count.
static uint32_t plTestMakeNetwork( plTestLayer* layers, uint32_t in, const uint32_t hidden[4], uint32_t out, float scale,
								   uint32_t* rng )
{
	uint32_t count = 0;
	for ( int i = 0; i < 4 && hidden[i] != 0; ++i )
	{
		plTestMakeLayer( &layers[count++], in, hidden[i], scale, rng );
		in = hidden[i];
	}
	plTestMakeLayer( &layers[count++], in, out, scale, rng );
	return count;
}

static void plTestFreeNetwork( plTestLayer* layers, uint32_t count )
{
	for ( uint32_t i = 0; i < count; ++i )
	{
		free( layers[i].weight );
		free( layers[i].bias );
	}
}

plTestAsset* plTestAsset_Create( const plTestAssetParams* p )
{
	plTestAsset* a = (plTestAsset*)calloc( 1, sizeof( plTestAsset ) );
	if ( a == NULL )
	{
		return NULL;
	}
	uint32_t rng = p->seed != 0 ? p->seed : 1;
	a->N = p->grid_x * p->grid_y;
	a->F = 2 * ( p->grid_x - 1 ) * ( p->grid_y - 1 );
	a->J = p->joint_count;
	a->Jin = p->input_joint_count;
	a->K = p->influence_count;
	a->B = p->beta_count;
	a->L = p->latent_count;
	a->D = p->blend_count;
	a->I = (uint32_t)plInputCountFormula( a->L, a->Jin, a->B );
	a->lp_activation = a->dec_activation = p->activation;
	a->dt_min_s = 1.0f / 240.0f;
	a->dt_max_s = 1.0f / 15.0f;
	a->beta_min = -4.0f;
	a->beta_max = 4.0f;
	const float mmin[4] = { 4.34e-2f, 15909.0f, 3535.41f, 6.37e-8f };
	const float mmax[4] = { 7e-1f, 63636.0f, 93333.73f, 1.31e-3f };
	for ( int i = 0; i < 4; ++i )
	{
		a->material_min[i] = mmin[i];
		a->material_max[i] = mmax[i];
		a->material_default[i] = 0.5f * ( mmin[i] + mmax[i] );
	}
	a->train_fps = 30.0f;
	strcpy( a->name, "test-sheet" );
	a->version_major = 1;
	a->fp16 = p->fp16;

	for ( uint32_t j = 0; j < a->J; ++j )
	{
		char* name = a->joint_names[j];
		memcpy( name, "joint_", 6 );
		name[6] = (char)( '0' + j / 10 );
		name[7] = (char)( '0' + j % 10 );
		a->parents[j] = (int32_t)j - 1;
		a->joint_template[j * 3 + 0] = 0.0f;
		a->joint_template[j * 3 + 1] = 0.25f * (float)j;
		a->joint_template[j * 3 + 2] = 0.0f;
	}
	for ( uint32_t i = 0; i < a->Jin; ++i )
	{
		a->input_joints[i] = i + 1;
	}
	a->joint_shapedirs = plTestFloats( (size_t)a->B * a->J * 3 );
	for ( size_t i = 0; i < (size_t)a->B * a->J * 3; ++i )
	{
		a->joint_shapedirs[i] = plTestUniform( &rng, 0.01f );
	}
	// A sheet in the XY plane, spanning the chain's height.
	float height = 0.25f * (float)( a->J > 1 ? a->J - 1 : 1 );
	a->template_positions = plTestFloats( (size_t)a->N * 3 );
	for ( uint32_t y = 0; y < p->grid_y; ++y )
	{
		for ( uint32_t x = 0; x < p->grid_x; ++x )
		{
			float* v = a->template_positions + ( (size_t)y * p->grid_x + x ) * 3;
			v[0] = -0.2f + 0.4f * (float)x / (float)( p->grid_x - 1 );
			v[1] = height * (float)y / (float)( p->grid_y - 1 );
			v[2] = 0.1f;
		}
	}
	a->faces = (uint32_t*)calloc( (size_t)a->F * 3, sizeof( uint32_t ) );
	uint32_t f = 0;
	for ( uint32_t y = 0; y + 1 < p->grid_y; ++y )
	{
		for ( uint32_t x = 0; x + 1 < p->grid_x; ++x )
		{
			uint32_t v00 = y * p->grid_x + x, v10 = v00 + 1, v01 = v00 + p->grid_x, v11 = v01 + 1;
			uint32_t* t = a->faces + (size_t)f * 3;
			t[0] = v00, t[1] = v10, t[2] = v11;
			t[3] = v00, t[4] = v11, t[5] = v01;
			f += 2;
		}
	}
	a->shape_blend = plTestFloats( (size_t)a->B * a->N * 3 );
	for ( size_t i = 0; i < (size_t)a->B * a->N * 3; ++i )
	{
		a->shape_blend[i] = plTestUniform( &rng, 0.01f );
	}
	// Skinning: the nearest joint below gets most weight, the next one up the rest.
	a->skin_indices = (uint16_t*)calloc( (size_t)a->N * a->K, sizeof( uint16_t ) );
	a->skin_weights = plTestFloats( (size_t)a->N * a->K );
	for ( uint32_t v = 0; v < a->N; ++v )
	{
		float t = a->template_positions[v * 3 + 1] / 0.25f;
		uint32_t j0 = (uint32_t)floorf( t );
		j0 = j0 >= a->J ? a->J - 1 : j0;
		float frac = t - (float)j0;
		for ( uint32_t k = 0; k < a->K; ++k )
		{
			uint32_t j = j0 + k < a->J ? j0 + k : a->J - 1;
			a->skin_indices[v * a->K + k] = (uint16_t)j;
		}
		if ( a->K == 1 )
		{
			a->skin_weights[v] = 1.0f;
		}
		else
		{
			a->skin_weights[v * a->K + 0] = 1.0f - 0.5f * frac;
			a->skin_weights[v * a->K + 1] = 0.5f * frac;
		}
	}
	a->x_mean = plTestFloats( a->I );
	a->x_std = plTestFloats( a->I );
	for ( uint32_t i = 0; i < a->I; ++i )
	{
		a->x_std[i] = 1.0f;
	}
	a->z_mean = plTestFloats( a->L );
	a->z_std = plTestFloats( a->L );
	a->z_min = plTestFloats( a->L );
	a->z_max = plTestFloats( a->L );
	for ( uint32_t i = 0; i < a->L; ++i )
	{
		a->z_std[i] = 1.0f;
		a->z_min[i] = -10.0f;
		a->z_max[i] = 10.0f;
	}
	a->lp_count = plTestMakeNetwork( a->lp, a->I, p->lp_hidden, a->L, p->weight_scale, &rng );
	a->dec_count = plTestMakeNetwork( a->dec, a->L, p->dec_hidden, a->D, p->weight_scale, &rng );
	a->blend_shapes = plTestFloats( (size_t)a->D * a->N * 3 );
	for ( size_t i = 0; i < (size_t)a->D * a->N * 3; ++i )
	{
		a->blend_shapes[i] = plTestUniform( &rng, p->blend_scale );
	}
	if ( p->int8_blend_shapes )
	{
		plTestAsset_QuantiseBlendShapes( a );
	}
	return a;
}

void plTestAsset_QuantiseBlendShapes( plTestAsset* a )
{
	size_t plane = (size_t)a->N * 3;
	a->blend_shapes_int8 = (int8_t*)malloc( plane * a->D );
	a->blend_scales = plTestFloats( a->D );
	for ( uint32_t j = 0; j < a->D; ++j )
	{
		float* shape = a->blend_shapes + j * plane;
		float peak = 0.0f;
		for ( size_t i = 0; i < plane; ++i )
		{
			peak = fabsf( shape[i] ) > peak ? fabsf( shape[i] ) : peak;
		}
		a->blend_scales[j] = peak > 0.0f ? peak / 127.0f : 1.0f;
		for ( size_t i = 0; i < plane; ++i )
		{
			float q = rintf( shape[i] / a->blend_scales[j] );
			a->blend_shapes_int8[j * plane + i] = (int8_t)( q < -127.0f ? -127.0f : q > 127.0f ? 127.0f : q );
			shape[i] = (float)a->blend_shapes_int8[j * plane + i] * a->blend_scales[j]; // what the file holds
		}
	}
	a->version_minor = a->version_minor > 4 ? a->version_minor : 4;
}

void plTestAsset_OverflowOnRootMotion( plTestAsset* a )
{
	a->x_mean[a->L] = 0.0f;
	a->x_std[a->L] = 1e-38f;
	for ( uint32_t r = 0; r < a->lp[0].out_count; ++r )
	{
		a->lp[0].weight[(size_t)r * a->lp[0].in_count + a->L] = ( r & 1u ) ? 6e4f : -6e4f;
	}
}

int plTestAsset_AddBodyAnchors( plTestAsset* a, float depth_m )
{
	uint32_t extra = ( a->N + 3 ) / 4;
	a->P = a->N + extra;
	a->C = 3;
	size_t p3 = (size_t)a->P * 3, pk = (size_t)a->P * a->K;
	a->body_anchors = (float*)malloc( p3 * sizeof( float ) );
	a->body_anchor_shape = (float*)malloc( ( a->B > 0 ? a->B : 1 ) * p3 * sizeof( float ) );
	a->body_anchor_normals = (float*)calloc( p3, sizeof( float ) );
	a->body_anchor_skin_indices = (uint16_t*)malloc( pk * sizeof( uint16_t ) );
	a->body_anchor_skin_weights = (float*)malloc( pk * sizeof( float ) );
	a->body_candidates = (uint16_t*)malloc( (size_t)a->N * a->C * sizeof( uint16_t ) );
	if ( a->body_anchors == NULL || a->body_anchor_shape == NULL || a->body_anchor_normals == NULL ||
		 a->body_anchor_skin_indices == NULL || a->body_anchor_skin_weights == NULL || a->body_candidates == NULL )
	{
		return 0;
	}
	for ( uint32_t p = 0; p < a->P; ++p )
	{
		uint32_t v = p < a->N ? p : 4 * ( p - a->N ); // the vertex the point sits behind
		float* r = a->body_anchors + 3 * (size_t)p;
		float* n = a->body_anchor_normals + 3 * (size_t)p;
		r[0] = a->template_positions[3 * v] + ( p < a->N ? 0.0f : 0.001f );
		r[1] = a->template_positions[3 * v + 1];
		r[2] = a->template_positions[3 * v + 2] - ( p < a->N ? depth_m : 0.5f * depth_m );
		if ( p >= a->N )
		{
			n[0] = 0.6f; // (0.6, 0, 0.8): unit
			n[2] = 0.8f;
		}
		else
		{
			n[2] = v % 5 == 0 ? 0.0f : 1.0f;
		}
		for ( uint32_t b = 0; b < a->B; ++b )
		{
			memcpy( a->body_anchor_shape + ( (size_t)b * a->P + p ) * 3, a->shape_blend + ( (size_t)b * a->N + v ) * 3,
					3 * sizeof( float ) );
		}
		memcpy( a->body_anchor_skin_indices + (size_t)p * a->K, a->skin_indices + (size_t)v * a->K,
				a->K * sizeof( uint16_t ) );
		memcpy( a->body_anchor_skin_weights + (size_t)p * a->K, a->skin_weights + (size_t)v * a->K,
				a->K * sizeof( float ) );
	}
	a->body_ring = (uint16_t*)malloc( (size_t)a->P * PLEAT_TEST_POINT_RING * sizeof( uint16_t ) );
	if ( a->body_ring == NULL )
	{
		return 0;
	}
	memset( a->body_ring, 0xFF, (size_t)a->P * PLEAT_TEST_POINT_RING * sizeof( uint16_t ) );
	// The grid's width: the vertices of row 0 share its y.
	uint32_t gx = 1;
	while ( gx < a->N && a->template_positions[3 * gx + 1] == a->template_positions[1] )
	{
		gx++;
	}
	uint32_t gy = a->N / gx;
	static const int ring_x[8] = { 1, 1, 0, -1, -1, -1, 0, 1 }, ring_y[8] = { 0, 1, 1, 1, 0, -1, -1, -1 }; // CCW
	for ( uint32_t y = 1; y + 1 < gy; ++y )
	{
		for ( uint32_t x = 1; x + 1 < gx; ++x )
		{
			uint16_t* ring = a->body_ring + (size_t)( y * gx + x ) * PLEAT_TEST_POINT_RING;
			for ( int i = 0; i < 8; ++i )
			{
				ring[i] = (uint16_t)( ( y + ring_y[i] ) * gx + x + ring_x[i] );
			}
		}
	}
	for ( uint32_t v = 0; v < a->N; ++v )
	{
		uint16_t* c = a->body_candidates + (size_t)v * a->C;
		int none = v % 7 == 3;
		c[0] = none ? 0xFFFFu : (uint16_t)v;
		c[1] = !none && v % 4 == 0 ? (uint16_t)( a->N + v / 4 ) : 0xFFFFu;
		c[2] = 0xFFFFu;
	}
	return 1;
}

void plTestAsset_DropBodyCandidates( plTestAsset* a )
{
	// The first N points are vertex v's own, in order: the 1.1 layout is their prefix of every array.
	if ( a->B > 0 )
	{
		for ( uint32_t b = 1; b < a->B; ++b )
		{
			memmove( a->body_anchor_shape + (size_t)b * a->N * 3, a->body_anchor_shape + (size_t)b * a->P * 3,
					 (size_t)a->N * 3 * sizeof( float ) );
		}
	}
	a->P = a->N;
	a->C = 1;
	free( a->body_candidates );
	a->body_candidates = NULL;
	free( a->body_ring );
	a->body_ring = NULL;
}

void plTestAsset_Destroy( plTestAsset* a )
{
	if ( a == NULL )
	{
		return;
	}
	free( a->body_anchors );
	free( a->body_anchor_shape );
	free( a->body_anchor_normals );
	free( a->body_anchor_skin_indices );
	free( a->body_anchor_skin_weights );
	free( a->body_candidates );
	free( a->body_ring );
	plTestFreeNetwork( a->lp, a->lp_count );
	plTestFreeNetwork( a->dec, a->dec_count );
	free( a->joint_shapedirs );
	free( a->template_positions );
	free( a->shape_blend );
	free( a->faces );
	free( a->skin_indices );
	free( a->skin_weights );
	free( a->x_mean );
	free( a->x_std );
	free( a->z_mean );
	free( a->z_std );
	free( a->z_min );
	free( a->z_max );
	free( a->blend_shapes );
	free( a->blend_shapes_int8 );
	free( a->blend_scales );
	free( a );
}

// ---- serialisation ----

typedef struct plTestSection
{
	char fourcc[4];
	uint32_t dtype, rank, dims[4];
	const void* data;  // source
	int widen_to_half; // data is float, store as fp16
	uint64_t size, offset;
	void* owned;
} plTestSection;

static void plPutU16( uint8_t* p, uint16_t v )
{
	p[0] = (uint8_t)v;
	p[1] = (uint8_t)( v >> 8 );
}

static void plPutU32( uint8_t* p, uint32_t v )
{
	for ( int i = 0; i < 4; ++i )
	{
		p[i] = (uint8_t)( v >> ( 8 * i ) );
	}
}

static void plPutU64( uint8_t* p, uint64_t v )
{
	for ( int i = 0; i < 8; ++i )
	{
		p[i] = (uint8_t)( v >> ( 8 * i ) );
	}
}

static void plPutF32( uint8_t* p, float f )
{
	uint32_t u;
	memcpy( &u, &f, 4 );
	plPutU32( p, u );
}

static plTestSection* plAddSection( plTestSection* list, uint32_t* count, const char* fourcc, uint32_t dtype,
									const void* data, uint32_t rank, uint32_t d0, uint32_t d1, uint32_t d2 )
{
	plTestSection* s = &list[( *count )++];
	memset( s, 0, sizeof( *s ) );
	memcpy( s->fourcc, fourcc, 4 );
	s->dtype = dtype;
	s->rank = rank;
	s->dims[0] = d0;
	s->dims[1] = rank > 1 ? d1 : 1;
	s->dims[2] = rank > 2 ? d2 : 1;
	s->dims[3] = 1;
	s->data = data;
	uint64_t elements = (uint64_t)s->dims[0] * s->dims[1] * s->dims[2];
	uint32_t es = ( dtype == 2 || dtype == 4 ) ? 2 : ( dtype == 6 || dtype == 7 ? 1 : 4 );
	s->size = elements * es;
	return s;
}

// A network's sections: weights <prefix>W<i> (stored fp16 when the asset is) and biases <prefix>B<i>.
static void plAddNetworkSections( plTestSection* list, uint32_t* count, const char prefix[2], const plTestLayer* layers,
								  uint32_t layer_count, int fp16 )
{
	for ( uint32_t i = 0; i < layer_count; ++i )
	{
		char w[5] = { prefix[0], prefix[1], 'W', (char)( '0' + i ), 0 };
		char b[5] = { prefix[0], prefix[1], 'B', (char)( '0' + i ), 0 };
		plAddSection( list, count, w, fp16 ? 2 : 1, layers[i].weight, 2, layers[i].out_count, layers[i].in_count, 1 )
			->widen_to_half = fp16;
		plAddSection( list, count, b, 1, layers[i].bias, 1, layers[i].out_count, 1, 1 );
	}
}

uint8_t* plTestAsset_Write( const plTestAsset* a, size_t* out_size )
{
	plTestSection sections[64];
	uint32_t count = 0;
	uint8_t conf[256];
	memset( conf, 0, sizeof( conf ) );
	// CONF: 13 counts, then from byte 52 the dt and β ranges, the material min/max/default and the training rate.
	uint32_t conf_u32[13] = { a->N, a->F, a->J, a->Jin, a->K, a->B, a->L, a->D, a->lp_count, a->dec_count,
							  a->lp_activation, a->dec_activation, a->I };
	float conf_f32[17] = { a->dt_min_s, a->dt_max_s, a->beta_min, a->beta_max };
	for ( int i = 0; i < 4; ++i )
	{
		conf_f32[4 + i] = a->material_min[i];
		conf_f32[8 + i] = a->material_max[i];
		conf_f32[12 + i] = a->material_default[i];
	}
	conf_f32[16] = a->train_fps;
	for ( int i = 0; i < 13; ++i )
	{
		plPutU32( conf + 4 * i, conf_u32[i] );
	}
	for ( int i = 0; i < 17; ++i )
	{
		plPutF32( conf + 52 + 4 * i, conf_f32[i] );
	}

	// CSR adjacency: faces of each vertex, ascending.
	uint32_t* nado = (uint32_t*)calloc( a->N + 1, sizeof( uint32_t ) );
	uint32_t* nadf = (uint32_t*)calloc( (size_t)a->F * 3 + 1, sizeof( uint32_t ) );
	for ( uint32_t i = 0; i < a->F * 3; ++i )
	{
		nado[a->faces[i] + 1] += 1;
	}
	for ( uint32_t v = 0; v < a->N; ++v )
	{
		nado[v + 1] += nado[v];
	}
	uint32_t* fill = (uint32_t*)calloc( a->N, sizeof( uint32_t ) );
	for ( uint32_t f = 0; f < a->F; ++f )
	{
		for ( int c = 0; c < 3; ++c )
		{
			uint32_t v = a->faces[f * 3 + c];
			nadf[nado[v] + fill[v]++] = f;
		}
	}
	free( fill );

	plAddSection( sections, &count, "CONF", 6, conf, 1, 256, 1, 1 );
	plAddSection( sections, &count, "NAME", 6, a->name, 1, (uint32_t)strlen( a->name ), 1, 1 );
	if ( a->meta != NULL )
	{
		plAddSection( sections, &count, "META", 6, a->meta, 1, (uint32_t)strlen( a->meta ), 1, 1 );
	}
	plAddSection( sections, &count, "JNAM", 6, a->joint_names, 2, a->J, 32, 1 );
	plAddSection( sections, &count, "JPAR", 5, a->parents, 1, a->J, 1, 1 );
	plAddSection( sections, &count, "JTPL", 1, a->joint_template, 2, a->J, 3, 1 );
	plAddSection( sections, &count, "JSHP", 1, a->joint_shapedirs, 3, a->B, a->J, 3 );
	plAddSection( sections, &count, "JINP", 3, a->input_joints, 1, a->Jin, 1, 1 );
	plAddSection( sections, &count, "TMPL", 1, a->template_positions, 2, a->N, 3, 1 );
	plAddSection( sections, &count, "SHPB", 1, a->shape_blend, 3, a->B, a->N, 3 );
	plAddSection( sections, &count, "FACE", 3, a->faces, 2, a->F, 3, 1 );
	plAddSection( sections, &count, "NADO", 3, nado, 1, a->N + 1, 1, 1 );
	plAddSection( sections, &count, "NADF", 3, nadf, 1, a->F * 3, 1, 1 );
	plAddSection( sections, &count, "SKNI", 4, a->skin_indices, 2, a->N, a->K, 1 );
	plAddSection( sections, &count, "SKNW", 1, a->skin_weights, 2, a->N, a->K, 1 );
	plAddSection( sections, &count, "XMEA", 1, a->x_mean, 1, a->I, 1, 1 );
	plAddSection( sections, &count, "XSTD", 1, a->x_std, 1, a->I, 1, 1 );
	plAddSection( sections, &count, "ZMEA", 1, a->z_mean, 1, a->L, 1, 1 );
	plAddSection( sections, &count, "ZSTD", 1, a->z_std, 1, a->L, 1, 1 );
	plAddSection( sections, &count, "ZMIN", 1, a->z_min, 1, a->L, 1, 1 );
	plAddSection( sections, &count, "ZMAX", 1, a->z_max, 1, a->L, 1, 1 );
	plAddNetworkSections( sections, &count, "LP", a->lp, a->lp_count, a->fp16 );
	plAddNetworkSections( sections, &count, "DC", a->dec, a->dec_count, a->fp16 );
	if ( a->blend_shapes_int8 != NULL )
	{
		plAddSection( sections, &count, "BLND", 7, a->blend_shapes_int8, 3, a->D, a->N, 3 );
		plAddSection( sections, &count, "BLSC", 1, a->blend_scales, 1, a->D, 1, 1 );
	}
	else
	{
		plAddSection( sections, &count, "BLND", a->fp16 ? 2 : 1, a->blend_shapes, 3, a->D, a->N, 3 )->widen_to_half =
			a->fp16;
	}
	if ( a->body_anchors != NULL )
	{
		plAddSection( sections, &count, "BANC", 1, a->body_anchors, 2, a->P, 3, 1 );
		plAddSection( sections, &count, "BASH", 1, a->body_anchor_shape, 3, a->B, a->P, 3 );
		plAddSection( sections, &count, "BANN", 1, a->body_anchor_normals, 2, a->P, 3, 1 );
		plAddSection( sections, &count, "BASI", 4, a->body_anchor_skin_indices, 2, a->P, a->K, 1 );
		plAddSection( sections, &count, "BASW", 1, a->body_anchor_skin_weights, 2, a->P, a->K, 1 );
		if ( a->body_candidates != NULL )
		{
			plAddSection( sections, &count, "BACA", 4, a->body_candidates, 2, a->N, a->C, 1 );
		}
		if ( a->body_ring != NULL )
		{
			plAddSection( sections, &count, "BARG", 4, a->body_ring, 2, a->P, PLEAT_TEST_POINT_RING, 1 );
		}
	}
	if ( a->onnx_lp != NULL )
	{
		plAddSection( sections, &count, "OXLP", 6, a->onnx_lp, 1, (uint32_t)a->onnx_lp_size, 1, 1 );
	}
	if ( a->onnx_dec != NULL )
	{
		plAddSection( sections, &count, "OXDC", 6, a->onnx_dec, 1, (uint32_t)a->onnx_dec_size, 1, 1 );
	}

	uint64_t offset = 128 + (uint64_t)count * 48;
	offset = ( offset + 63 ) & ~(uint64_t)63;
	for ( uint32_t i = 0; i < count; ++i )
	{
		sections[i].offset = offset;
		offset += sections[i].size;
		offset = ( offset + 63 ) & ~(uint64_t)63;
	}
	size_t size = (size_t)offset;
	uint8_t* bytes = (uint8_t*)aligned_alloc( 64, ( size + 63 ) & ~(size_t)63 );
	if ( bytes == NULL )
	{
		free( nado );
		free( nadf );
		return NULL;
	}
	memset( bytes, 0, size );
	memcpy( bytes, "PLEATAST", 8 );
	plPutU16( bytes + 8, a->version_major );
	plPutU16( bytes + 10, a->version_minor );
	plPutU32( bytes + 12, 128 );
	plPutU64( bytes + 16, size );
	plPutU32( bytes + 24, count );
	plPutU32( bytes + 28, ( a->fp16 ? 1u : 0u ) | ( a->blend_shapes_int8 != NULL ? 8u : 0u ) );
	plPutU64( bytes + 32, 128 );
	for ( uint32_t i = 0; i < count; ++i )
	{
		const plTestSection* s = &sections[i];
		uint8_t* e = bytes + 128 + (size_t)i * 48;
		memcpy( e, s->fourcc, 4 );
		plPutU32( e + 4, s->dtype );
		plPutU32( e + 8, s->rank );
		plPutU64( e + 16, s->offset );
		plPutU64( e + 24, s->size );
		for ( int d = 0; d < 4; ++d )
		{
			plPutU32( e + 32 + 4 * d, s->dims[d] );
		}
		if ( s->widen_to_half )
		{
			uint16_t* dst = (uint16_t*)( bytes + s->offset );
			const float* src = (const float*)s->data;
			for ( uint64_t k = 0; k < s->size / 2; ++k )
			{
				dst[k] = plFloatToHalf( src[k] );
			}
		}
		else if ( s->size > 0 )
		{
			memcpy( bytes + s->offset, s->data, (size_t)s->size );
		}
	}
	free( nado );
	free( nadf );
	plTestAsset_FixChecksum( bytes, size );
	*out_size = size;
	return bytes;
}

void plTestAsset_FreeBytes( uint8_t* bytes )
{
	free( bytes );
}

void plTestAsset_FixChecksum( uint8_t* bytes, size_t size )
{
	memset( bytes + 40, 0, 4 );
	plPutU32( bytes + 40, plCrc32( 0, bytes, size ) );
}

size_t plTestAsset_SectionEntryOffset( const uint8_t* bytes, const char* fourcc )
{
	uint32_t count;
	memcpy( &count, bytes + 24, 4 );
	for ( uint32_t i = 0; i < count && i < 256; ++i )
	{
		const uint8_t* e = bytes + 128 + (size_t)i * 48;
		if ( memcmp( e, fourcc, 4 ) == 0 )
		{
			return 128 + (size_t)i * 48;
		}
	}
	return 0;
}

size_t plTestAsset_SectionOffset( const uint8_t* bytes, const char* fourcc )
{
	size_t e = plTestAsset_SectionEntryOffset( bytes, fourcc );
	if ( e == 0 )
	{
		return 0;
	}
	uint64_t offset;
	memcpy( &offset, bytes + e + 16, 8 );
	return (size_t)offset;
}

uint64_t plTestHash( const void* data, size_t size, uint64_t seed )
{
	uint64_t h = seed != 0 ? seed : 1469598103934665603ull;
	const uint8_t* p = (const uint8_t*)data;
	for ( size_t i = 0; i < size; ++i )
	{
		h ^= p[i];
		h *= 1099511628211ull;
	}
	return h;
}
