// int8 networks (asset 1.3): every int8 mat-vec this build has and this CPU runs gives the scalar kernel's bits, and
// the scalar kernel the specification's, for each place an input is quantised to; the MLP job on a packed int8 asset
// (ranged inputs, and the symmetric ones) gives the numpy reference's bits (pleat.reference.mlp.mlp_int8) with every
// kernel set, one instance or a batch; the loader refuses what the int8 kernels cannot run.
//
// usage: test_int8_matches_reference [DIR]   (DIR/asset.pleat and DIR/mlp_case.bin from pleat-golden-int8, i.e.
// python -m pleat.reference.golden_int8). The kernel test needs no data; without DIR the data tests are skipped.
//
// No tolerance anywhere: the products are summed in integers, and the float steps (quantising, dequantising, the
// bias, ReLU) are the same IEEE operations in C and numpy.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "asset.h"
#include "asset_data.h"
#include "jobs.h"
#include "jobs_batch.h"
#include "test_common.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char* s_dir;
static uint32_t s_rng = 4242;

static uint32_t plRandU32( void )
{
	s_rng = s_rng * 1103515245u + 12345u;
	return s_rng >> 8;
}

// A random int8 layer for the kernel tests: weights mostly at the extremes ±127, where a saturating scheme would
// fail, and zeros (block layers); row scales and biases; input scale 2 (so with inv 0.5, x = 2k + 1 lands on a tie).
typedef struct plRandomInt8Layer
{
	plLayer layer;
	int8_t* w;
	float *scale, *bias;
	int32_t* sums;
	float input_scale;
} plRandomInt8Layer;

static void plMakeRandomInt8Layer( plRandomInt8Layer* t, uint32_t in, uint32_t out, uint32_t input )
{
	t->w = (int8_t*)malloc( (size_t)in * out );
	t->scale = (float*)malloc( out * sizeof( float ) );
	t->bias = (float*)malloc( out * sizeof( float ) );
	t->sums = (int32_t*)malloc( out * sizeof( int32_t ) );
	for ( size_t i = 0; i < (size_t)in * out; ++i )
	{
		uint32_t r = plRandU32() % 8;
		t->w[i] = (int8_t)( r == 0 ? 127 : r == 1 ? -127 : r == 2 ? 0 : (int)( plRandU32() % 255 ) - 127 );
	}
	for ( uint32_t r = 0; r < out; ++r )
	{
		t->scale[r] = 1e-3f * (float)( 1 + plRandU32() % 1000 );
		t->bias[r] = (float)( plRandU32() % 1000 ) / 500.0f - 1.0f;
	}
	t->input_scale = 2.0f;
	memset( &t->layer, 0, sizeof( t->layer ) );
	t->layer.weight = t->w;
	t->layer.weight_int8 = 1;
	t->layer.weight_scale = t->scale;
	t->layer.input_scale = &t->input_scale;
	t->layer.input_inv_scale = 0.5f;
	t->layer.bias = t->bias;
	t->layer.in_count = in;
	t->layer.out_count = out;
	t->layer.int8_input = input;
	t->layer.weight_sums = t->sums;
}

// The row sums over a window [cb, ce), as the load derives them for a block layer's (weight_sums).
static void plSetWindowSums( plRandomInt8Layer* t, uint32_t cb, uint32_t ce )
{
	for ( uint32_t r = 0; r < t->layer.out_count; ++r )
	{
		int32_t sum = 0;
		for ( uint32_t c = cb; c < ce; ++c )
		{
			sum += t->w[(size_t)r * t->layer.in_count + c];
		}
		t->sums[r] = sum;
	}
}

static void plFreeRandomInt8Layer( plRandomInt8Layer* t )
{
	free( t->w );
	free( t->scale );
	free( t->bias );
	free( t->sums );
}

// The specification written out once more, with the input's true quantised value (q, not the held q − 128) and a
// 64-bit sum: what every kernel must give, offsets and all.
static float plExpectedRow( const float* x, const plLayer* l, const int8_t* w, uint32_t cb, uint32_t ce, uint32_t r )
{
	int64_t acc = 0;
	for ( uint32_t c = cb; c < ce; ++c )
	{
		int32_t q = plQuantiseWithin( x[c], l->input_inv_scale, plInt8InputLow( l->int8_input ),
									  plInt8InputHigh( l->int8_input ) );
		acc += (int64_t)w[(size_t)r * l->in_count + c] * q;
	}
	return plDequantise( (int32_t)acc, l->weight_scale[r], l->input_scale[0], l->bias[r] );
}

// Shapes past each step of the kernels (16, 32 and 64 columns, four rows at a time) and windows of block layers, for
// each place an input is quantised to (symmetric, a ranged network's first layer, its hidden layers).
static void test_every_int8_kernel_gives_the_scalar_bits( void** state )
{
	(void)state;
	plMatVecInt8Fn* kernels[8];
	const char* names[8];
	uint32_t count = plInt8MatVecVariants( kernels, names, 8 );
	assert_true( count >= 1 );
	assert_ptr_equal( kernels[0], plMatVecInt8_Scalar );
	printf( "int8 mat-vec variants on this CPU:" );
	for ( uint32_t v = 0; v < count; ++v )
	{
		printf( " %s", names[v] );
	}
	printf( "\n" );
	static const uint32_t columns[] = { 1, 7, 15, 16, 17, 31, 32, 33, 63, 64, 65, 100, 129, 681, PLEAT_MAX_INT8_COLUMNS };
	static const uint32_t rows[] = { 1, 3, 4, 5, 9, 64, 130 };
	static const uint32_t inputs[] = { PLEAT_INT8_INPUT_SYMMETRIC, PLEAT_INT8_INPUT_FIRST, PLEAT_INT8_INPUT_HIDDEN };
	for ( size_t ki = 0; ki < 3; ++ki )
	{
		for ( size_t ci = 0; ci < sizeof( columns ) / sizeof( columns[0] ); ++ci )
		{
			for ( size_t ri = 0; ri < sizeof( rows ) / sizeof( rows[0] ); ++ri )
			{
				uint32_t in = columns[ci], out = rows[ri];
				plRandomInt8Layer t;
				plMakeRandomInt8Layer( &t, in, out, inputs[ki] );
				const int8_t* w = t.w;
				float* x = (float*)malloc( in * sizeof( float ) );
				float* expect = (float*)malloc( out * sizeof( float ) );
				float* got = (float*)malloc( out * sizeof( float ) );
				// inv_scale 0.5: x = 2k + 1 lands on k + 0.5 exactly (the ties to even); past every bound the
				// clamp (±254, 0..510, ±4094); and the values that are not numbers (a NaN quantises to the low bound)
				for ( uint32_t c = 0; c < in; ++c )
				{
					uint32_t r = plRandU32() % 16;
					x[c] = r == 0	? (float)( 2 * (int)( plRandU32() % 4095 ) - 4094 + 1 )
						   : r == 1 ? 10000.0f * ( plRandU32() % 2 ? 1.0f : -1.0f )
						   : r == 2 ? ( plRandU32() % 2 ? NAN : -INFINITY )
						   : r == 3 ? (float)( 2 * (int)( plRandU32() % 255 ) + 1 )
									: ( (float)( plRandU32() % 100000 ) / 50000.0f - 1.0f ) * 300.0f;
				}
				const plLayer* layer = &t.layer;
				// whole rows, then a window [16, in) where it exists (a block layer's), then a row range inside
				uint32_t windows[3][4] = { { 0, in, 0, out },
										   { in > 16 ? 16u : 0u, in, 0, out },
										   { 0, in, out / 3, out - out / 4 } };
				for ( int wi = 0; wi < 3; ++wi )
				{
					uint32_t cb = windows[wi][0], ce = windows[wi][1], rb = windows[wi][2], re = windows[wi][3];
					if ( rb >= re )
					{
						continue;
					}
					plSetWindowSums( &t, cb, ce );
					memset( expect, 0, out * sizeof( float ) );
					kernels[0]( expect, x, layer, w, in, cb, ce, rb, re );
					for ( uint32_t r = rb; r < re; ++r )
					{
						float spec = plExpectedRow( x, layer, w, cb, ce, r );
						if ( memcmp( &spec, &expect[r], sizeof( float ) ) != 0 )
						{
							fail_msg( "scalar differs from the specification: input %u, %u columns, row %u",
									  inputs[ki], in, r );
						}
					}
					for ( uint32_t v = 1; v < count; ++v )
					{
						memset( got, 0, out * sizeof( float ) );
						kernels[v]( got, x, layer, w, in, cb, ce, rb, re );
						if ( memcmp( got, expect, out * sizeof( float ) ) != 0 )
						{
							fail_msg( "%s differs from scalar: input %u, %u columns [%u, %u), rows [%u, %u)", names[v],
									  inputs[ki], in, cb, ce, rb, re );
						}
					}
				}
				plFreeRandomInt8Layer( &t );
				free( x );
				free( expect );
				free( got );
			}
		}
	}
}

// The batched int8 kernels (the crowd's: weights shared between instances) give each instance the single scalar
// kernel's bits, for every input kind, on shapes past each step (4, 16, 32, 64 columns; 8 rows; 16 instances), over a
// whole row and over a block's window.
static void test_batched_int8_kernels_give_the_single_bits( void** state )
{
	(void)state;
	plKernels sets[3];
	plKernelSet wanted[3] = { PLEAT_KERNEL_SET_SCALAR, PLEAT_KERNEL_SET_AVX2, PLEAT_KERNEL_SET_AVX512 };
	static const uint32_t columns[] = { 1, 3, 15, 17, 33, 63, 64, 65, 129, 681 };
	static const uint32_t rows[] = { 1, 3, 9, 17, 64 };
	static const uint32_t inputs[] = { PLEAT_INT8_INPUT_SYMMETRIC, PLEAT_INT8_INPUT_FIRST, PLEAT_INT8_INPUT_HIDDEN };
	enum { B = 19 };
	for ( size_t ki = 0; ki < 3; ++ki )
	{
		for ( size_t ci = 0; ci < sizeof( columns ) / sizeof( columns[0] ); ++ci )
		{
			for ( size_t ri = 0; ri < sizeof( rows ) / sizeof( rows[0] ); ++ri )
			{
				uint32_t in = columns[ci], out = rows[ri];
				plRandomInt8Layer t;
				plMakeRandomInt8Layer( &t, in, out, inputs[ki] );
				const int8_t* w = t.w;
				const plLayer* layer = &t.layer;
				float* x = (float*)malloc( (size_t)B * in * sizeof( float ) );
				float* expect = (float*)malloc( (size_t)B * out * sizeof( float ) );
				float* got = (float*)malloc( (size_t)B * out * sizeof( float ) );
				for ( size_t c = 0; c < (size_t)B * in; ++c )
				{
					uint32_t r = plRandU32() % 16;
					x[c] = r == 0 ? 10000.0f * ( plRandU32() % 2 ? 1.0f : -1.0f )
						   : r == 1 ? NAN
									: ( (float)( plRandU32() % 100000 ) / 50000.0f - 1.0f ) * 600.0f;
				}
				float* outs[B];
				const float* xs[B];
				for ( uint32_t b = 0; b < B; ++b )
				{
					outs[b] = got + (size_t)b * out;
					xs[b] = x + (size_t)b * in;
				}
				void* held = aligned_alloc( 64, plInt8HeldBlockBytes( layer, B ) );
				static const uint32_t begins[2] = { 0, 16 }; // the whole row, then a window [16, in) where there is one
				for ( uint32_t wi = 0; wi < 2 && begins[wi] < in; ++wi )
				{
					uint32_t cb = begins[wi];
					plSetWindowSums( &t, cb, in );
					for ( uint32_t b = 0; b < B; ++b )
					{
						plMatVecInt8_Scalar( expect + (size_t)b * out, xs[b], layer, w, in, cb, in, 0, out );
					}
					for ( int s = 0; s < 3; ++s )
					{
						if ( plChooseKernels( &sets[s], wanted[s] ) != wanted[s] || sets[s].mat_mat_int8 == NULL )
						{
							continue;
						}
						for ( uint32_t n = 1; n <= B; n += B - 1 ) // one instance, then more than a group of 16
						{
							sets[s].quantise_int8( held, xs, n, layer );
							memset( got, 0, (size_t)B * out * sizeof( float ) );
							sets[s].mat_mat_int8( outs, held, n, layer, w + cb, in, cb, in - cb, 0, out );
							if ( memcmp( got, expect, (size_t)n * out * sizeof( float ) ) != 0 )
							{
								fail_msg( "set %d's batched int8 kernel differs: input %u, columns [%u, %u), %u rows, "
										  "%u instances",
										  (int)wanted[s], inputs[ki], cb, in, out, n );
							}
						}
					}
				}
				free( held );
				plFreeRandomInt8Layer( &t );
				free( x );
				free( expect );
				free( got );
			}
		}
	}
}

// The rounding rule itself: ties to even, the clamps, NaN to the low bound; a hidden input is held as q − 128.
static void test_quantise_rounds_ties_to_even_and_clamps( void** state )
{
	(void)state;
	assert_int_equal( plQuantise( 0.5f, 1.0f ), 0 );
	assert_int_equal( plQuantise( 1.5f, 1.0f ), 2 );
	assert_int_equal( plQuantise( 2.5f, 1.0f ), 2 );
	assert_int_equal( plQuantise( -2.5f, 1.0f ), -2 );
	assert_int_equal( plQuantise( 126.5f, 1.0f ), 126 );
	assert_int_equal( plQuantise( 300.0f, 1.0f ), 127 );
	assert_int_equal( plQuantise( -300.0f, 1.0f ), -127 );
	assert_int_equal( plQuantise( NAN, 1.0f ), -127 );
	assert_int_equal( plQuantise( INFINITY, 1.0f ), 127 );
	assert_int_equal( plQuantiseInput( 2046.5f, 1.0f, PLEAT_INT8_INPUT_FIRST ), 2046 );
	assert_int_equal( plQuantiseInput( 5000.0f, 1.0f, PLEAT_INT8_INPUT_FIRST ), 2047 );
	assert_int_equal( plQuantiseInput( -5000.0f, 1.0f, PLEAT_INT8_INPUT_FIRST ), -2047 );
	assert_int_equal( plQuantiseInput( NAN, 1.0f, PLEAT_INT8_INPUT_FIRST ), -2047 );
	assert_int_equal( plQuantiseInput( 0.0f, 1.0f, PLEAT_INT8_INPUT_HIDDEN ), -128 );
	assert_int_equal( plQuantiseInput( -3.0f, 1.0f, PLEAT_INT8_INPUT_HIDDEN ), -128 );
	assert_int_equal( plQuantiseInput( 128.5f, 1.0f, PLEAT_INT8_INPUT_HIDDEN ), 0 );
	assert_int_equal( plQuantiseInput( 300.0f, 1.0f, PLEAT_INT8_INPUT_HIDDEN ), 127 );
	assert_int_equal( plQuantiseInput( NAN, 1.0f, PLEAT_INT8_INPUT_HIDDEN ), -128 );
}

typedef struct plInt8Case
{
	uint32_t rows, I, L, D;
	float *x, *y, *z, *w;
	float* data;
} plInt8Case;

static int plReadInt8Case( const char* path, plInt8Case* c )
{
	FILE* f = fopen( path, "rb" );
	if ( f == NULL )
	{
		return 0;
	}
	char magic[8];
	uint32_t head[5];
	int ok = fread( magic, 1, 8, f ) == 8 && memcmp( magic, "PLINT8MC", 8 ) == 0 && fread( head, 4, 5, f ) == 5 &&
			 head[0] == 1;
	if ( ok )
	{
		c->rows = head[1];
		c->I = head[2];
		c->L = head[3];
		c->D = head[4];
		size_t floats = (size_t)c->rows * ( c->I + 2 * c->L + c->D );
		c->data = (float*)malloc( floats * sizeof( float ) );
		ok = fread( c->data, sizeof( float ), floats, f ) == floats;
		c->x = c->data;
		c->y = c->x + (size_t)c->rows * c->I;
		c->z = c->y + (size_t)c->rows * c->L;
		c->w = c->z + (size_t)c->rows * c->L;
	}
	fclose( f );
	return ok;
}

static uint8_t* plReadFile( const char* path, size_t* size )
{
	FILE* f = fopen( path, "rb" );
	if ( f == NULL )
	{
		return NULL;
	}
	fseek( f, 0, SEEK_END );
	long n = ftell( f );
	fseek( f, 0, SEEK_SET );
	uint8_t* bytes = (uint8_t*)aligned_alloc( 64, ( (size_t)n + 63 ) & ~(size_t)63 );
	if ( fread( bytes, 1, (size_t)n, f ) != (size_t)n )
	{
		free( bytes );
		bytes = NULL;
	}
	fclose( f );
	*size = (size_t)n;
	return bytes;
}

// One network over every row with one kernel table: single jobs, then one batched job; each output is the reference's.
static void plCheckNetwork( const plKernels* k, const plLayer* layers, uint32_t layer_count, uint32_t activation,
							const float* in, uint32_t in_count, const float* expect, uint32_t out_count, uint32_t rows,
							const char* what )
{
	float scratch[2 * 1024];
	float* out = (float*)malloc( (size_t)rows * out_count * sizeof( float ) );
	for ( uint32_t m = 0; m < rows; ++m )
	{
		plMlpJob job = { layers,
						 layer_count,
						 activation,
						 plMakeConstSpan( in + (size_t)m * in_count, in_count, 4 ),
						 plMakeSpan( out + (size_t)m * out_count, out_count, 4 ),
						 plMakeSpan( scratch, 2 * 1024, 4 ),
						 k,
						 NULL };
		assert_int_equal( plMlpJob_Run( &job ), PLEAT_RESULT_OK );
	}
	if ( memcmp( out, expect, (size_t)rows * out_count * sizeof( float ) ) != 0 )
	{
		fail_msg( "%s (kernel set %d): the single job differs from numpy", what, (int)k->set );
	}
	uint32_t batch = rows < PLEAT_BATCH_MAX ? rows : PLEAT_BATCH_MAX;
	plConstSpan inputs[PLEAT_BATCH_MAX];
	plSpan outputs[PLEAT_BATCH_MAX], scratches[PLEAT_BATCH_MAX];
	float* batch_scratch = (float*)malloc( (size_t)batch * 2 * 1024 * sizeof( float ) );
	memset( out, 0, (size_t)rows * out_count * sizeof( float ) );
	for ( uint32_t b = 0; b < batch; ++b )
	{
		inputs[b] = plMakeConstSpan( in + (size_t)b * in_count, in_count, 4 );
		outputs[b] = plMakeSpan( out + (size_t)b * out_count, out_count, 4 );
		scratches[b] = plMakeSpan( batch_scratch + (size_t)b * 2 * 1024, 2 * 1024, 4 );
	}
	plMlpBatchJob job = { layers,	 layer_count, activation, batch, inputs, outputs, scratches, k->batch, NULL, NULL, 0,
						  k->mat_vec_int8, NULL, NULL };
	assert_int_equal( plMlpBatchJob_Run( &job ), PLEAT_RESULT_OK );
	if ( memcmp( out, expect, (size_t)batch * out_count * sizeof( float ) ) != 0 )
	{
		fail_msg( "%s (kernel set %d): the batched job differs from numpy", what, (int)k->set );
	}
	// the set's batched int8 kernel where it has one, on the held inputs in the lanes scratch
	size_t held_floats = plMlpBatchHeldFloats( layers, layer_count, batch );
	float* held = (float*)aligned_alloc( 64, ( held_floats * sizeof( float ) + 63 ) & ~(size_t)63 );
	job.mat_mat_int8 = k->mat_mat_int8;
	job.quantise_int8 = k->quantise_int8;
	job.lanes = held;
	job.lanes_floats = held_floats;
	memset( out, 0, (size_t)rows * out_count * sizeof( float ) );
	assert_int_equal( plMlpBatchJob_Run( &job ), PLEAT_RESULT_OK );
	if ( memcmp( out, expect, (size_t)batch * out_count * sizeof( float ) ) != 0 )
	{
		fail_msg( "%s (kernel set %d): the batched job with the batched int8 kernel differs from numpy", what,
				  (int)k->set );
	}
	job.quantise_int8 = NULL; // one of the pair without the other is an invalid job
	assert_int_equal( plMlpBatchJob_Run( &job ), k->mat_mat_int8 != NULL ? PLEAT_RESULT_INVALID_ARGUMENT
																		  : PLEAT_RESULT_OK );
	job.mat_mat_int8 = NULL;
	job.mat_vec_int8 = NULL; // an int8 layer without its kernel is an invalid job
	assert_int_equal( plMlpBatchJob_Run( &job ), PLEAT_RESULT_INVALID_ARGUMENT );
	free( held );
	free( batch_scratch );
	free( out );
}

// One case of pleat-golden-int8 (suffix "" ranged inputs, "_symmetric" the first int8 assets' scheme).
static void plCheckInt8Case( const char* suffix, uint32_t first_input, uint32_t hidden_input )
{
	char path[4096];
	snprintf( path, sizeof( path ), "%s/mlp_case%s.bin", s_dir, suffix );
	plInt8Case c;
	memset( &c, 0, sizeof( c ) );
	assert_true( plReadInt8Case( path, &c ) );
	plContextDef cdef = plDefaultContextDef();
	plContext ctx;
	assert_int_equal( plCreateContext( &cdef, &ctx ), PLEAT_RESULT_OK );
	plAssetDef adef = plDefaultAssetDef();
	snprintf( path, sizeof( path ), "%s/asset%s.pleat", s_dir, suffix );
	adef.path = path;
	plAsset asset;
	assert_int_equal( plLoadAsset( ctx, &adef, &asset ), PLEAT_RESULT_OK );
	plAssetInfo info;
	assert_int_equal( plAsset_GetInfo( asset, &info ), PLEAT_RESULT_OK );
	assert_true( info.weights_int8 );
	const plAssetData* a = plGetAssetData( asset );
	assert_int_equal( a->input_count, c.I );
	assert_int_equal( a->latent_count, c.L );
	assert_int_equal( a->blend_count, c.D );
	for ( uint32_t i = 0; i < a->lp_layer_count; ++i )
	{
		assert_true( a->lp[i].weight_int8 );
		assert_int_equal( a->lp[i].int8_input, i == 0 ? first_input : hidden_input );
		assert_non_null( a->lp[i].weight_sums );
	}
	assert_int_equal( a->dec[0].int8_input, first_input );
	plKernelSet sets[3] = { PLEAT_KERNEL_SET_SCALAR, PLEAT_KERNEL_SET_AVX2, PLEAT_KERNEL_SET_AVX512 };
	for ( int s = 0; s < 3; ++s )
	{
		plKernels k;
		if ( plChooseKernels( &k, sets[s] ) != sets[s] )
		{
			continue; // a set this build or CPU does not have
		}
		plCheckNetwork( &k, a->lp, a->lp_layer_count, a->lp_activation, c.x, c.I, c.y, c.L, c.rows, "f_LP" );
		plCheckNetwork( &k, a->dec, a->dec_layer_count, a->dec_activation, c.z, c.L, c.w, c.D, c.rows, "f_dec" );
	}
	plDestroyAsset( asset );
	plDestroyContext( ctx );
	free( c.data );
}

static void test_int8_networks_give_the_numpy_reference_bits( void** state )
{
	(void)state;
	if ( s_dir == NULL )
	{
		skip();
	}
	plCheckInt8Case( "", PLEAT_INT8_INPUT_FIRST, PLEAT_INT8_INPUT_HIDDEN );
	plCheckInt8Case( "_symmetric", PLEAT_INT8_INPUT_SYMMETRIC, PLEAT_INT8_INPUT_SYMMETRIC );
}

// The section's entry in a loaded buffer (the table layout of docs/asset-format.md), or NULL.
static uint8_t* plSectionEntry( uint8_t* bytes, const char* fourcc )
{
	uint32_t count;
	memcpy( &count, bytes + 24, 4 );
	for ( uint32_t i = 0; i < count; ++i )
	{
		uint8_t* e = bytes + 128 + 48 * i;
		if ( memcmp( e, fourcc, 4 ) == 0 )
		{
			return e;
		}
	}
	return NULL;
}

static plResult plLoadEdited( plContext ctx, const uint8_t* bytes, size_t size )
{
	plAssetDef adef = plDefaultAssetDef();
	adef.data = bytes;
	adef.size = size;
	adef.flags = PLEAT_ASSET_FLAG_SKIP_CHECKSUM;
	plAsset asset;
	plResult r = plLoadAsset( ctx, &adef, &asset );
	if ( r == PLEAT_RESULT_OK )
	{
		plDestroyAsset( asset );
	}
	return r;
}

// What the int8 kernels cannot run is refused at load: a −128 weight, a zero scale, a missing scale section, int8
// weights without the header's flag (an older reader's view: the flag is unknown there, so it refuses the file), an
// unknown flag, ranged inputs without int8 networks or on a SiLU network.
static void test_loader_refuses_what_the_int8_kernels_cannot_run( void** state )
{
	(void)state;
	if ( s_dir == NULL )
	{
		skip();
	}
	char path[4096];
	snprintf( path, sizeof( path ), "%s/asset.pleat", s_dir );
	size_t size = 0;
	uint8_t* original = plReadFile( path, &size );
	assert_non_null( original );
	uint8_t* bytes = (uint8_t*)aligned_alloc( 64, ( size + 63 ) & ~(size_t)63 );
	plContextDef cdef = plDefaultContextDef();
	plContext ctx;
	assert_int_equal( plCreateContext( &cdef, &ctx ), PLEAT_RESULT_OK );
	memcpy( bytes, original, size );
	assert_int_equal( plLoadEdited( ctx, bytes, size ), PLEAT_RESULT_OK );

	uint64_t offset;
	memcpy( bytes, original, size );
	memcpy( &offset, plSectionEntry( bytes, "LPW1" ) + 16, 8 );
	bytes[offset + 5] = 0x80; // −128
	assert_int_equal( plLoadEdited( ctx, bytes, size ), PLEAT_RESULT_INVALID_ASSET_DATA );

	memcpy( bytes, original, size );
	memcpy( &offset, plSectionEntry( bytes, "DCS0" ) + 16, 8 );
	memset( bytes + offset + 4, 0, 4 ); // a zero output-channel scale
	assert_int_equal( plLoadEdited( ctx, bytes, size ), PLEAT_RESULT_INVALID_ASSET_DATA );

	memcpy( bytes, original, size );
	memcpy( &offset, plSectionEntry( bytes, "LPA0" ) + 16, 8 );
	float denormal = 1e-40f; // positive, but 1 / it is not finite
	memcpy( bytes + offset, &denormal, 4 );
	assert_int_equal( plLoadEdited( ctx, bytes, size ), PLEAT_RESULT_INVALID_ASSET_DATA );

	memcpy( bytes, original, size );
	memcpy( plSectionEntry( bytes, "LPA1" ), "XXXX", 4 ); // the input scale missing
	assert_int_equal( plLoadEdited( ctx, bytes, size ), PLEAT_RESULT_INVALID_ASSET_DATA );

	memcpy( bytes, original, size );
	uint32_t flags = 0;
	memcpy( bytes + 28, &flags, 4 ); // int8 weights where the header promises float ones
	assert_int_equal( plLoadEdited( ctx, bytes, size ), PLEAT_RESULT_INVALID_ASSET_DATA );

	memcpy( bytes, original, size );
	flags = 16; // a flag no reader knows
	memcpy( bytes + 28, &flags, 4 );
	assert_int_equal( plLoadEdited( ctx, bytes, size ), PLEAT_RESULT_MALFORMED_ASSET );

	memcpy( bytes, original, size );
	flags = 4; // ranged inputs without int8 networks
	memcpy( bytes + 28, &flags, 4 );
	assert_int_equal( plLoadEdited( ctx, bytes, size ), PLEAT_RESULT_INVALID_ASSET_DATA );

	memcpy( bytes, original, size );
	memcpy( &offset, plSectionEntry( bytes, "CONF" ) + 16, 8 );
	uint32_t silu = 2; // ranged inputs on a SiLU network, whose hidden inputs can be negative
	memcpy( bytes + offset + 44, &silu, 4 );
	assert_int_equal( plLoadEdited( ctx, bytes, size ), PLEAT_RESULT_INVALID_ASSET_DATA );

	plDestroyContext( ctx );
	free( bytes );
	free( original );
}

int main( int argc, char** argv )
{
	if ( argc > 1 )
	{
		s_dir = argv[1];
	}
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_every_int8_kernel_gives_the_scalar_bits ),
		cmocka_unit_test( test_batched_int8_kernels_give_the_single_bits ),
		cmocka_unit_test( test_quantise_rounds_ties_to_even_and_clamps ),
		cmocka_unit_test( test_int8_networks_give_the_numpy_reference_bits ),
		cmocka_unit_test( test_loader_refuses_what_the_int8_kernels_cannot_run ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
