// The batched kernels and jobs (kernels_batch.h, jobs_batch.h) give, for every instance of a batch, exactly what the
// single-instance kernel or job of the same kernel set gives for that instance alone — bit for bit, on shapes that
// exercise the 16/8-wide steps, the scalar tails, odd row ranges, leftover instances of the register tiles and
// leftover elements of the blend tiles, fp32 and fp16. The batched AVX2 kernels are also held to the scalar
// specification with the tolerance test_simd_matches_scalar uses (a different summation order, FMA vs two roundings).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "jobs_batch.h"
#include "test_blend_shapes.h"
#include "test_common.h"

static uint32_t s_rng = 4242;

static float plRand( void )
{
	return plTestRandom( &s_rng );
}

// The kernel sets to compare: scalar always, AVX2 when this build and CPU have it, and the AVX2 single-instance
// kernels with the AVX-512 batched ones when this build and CPU have those too (set 2). Each set's batched kernels are
// held to the single-instance kernels of the same set.
#define PLEAT_TEST_SETS 3
typedef struct plTestSets
{
	plKernels single[PLEAT_TEST_SETS];
	plBatchKernels batch[PLEAT_TEST_SETS];
	uint32_t count;
} plTestSets;

// cmocka setup: *state = the kernel sets (chosen once, reported once).
static int plKernelSets_Setup( void** state )
{
	static plTestSets sets;
	if ( sets.count == 0 )
	{
		// Each set this build has and this CPU runs: plChooseKernels gives a narrower one when asked for one it lacks.
		for ( int set = PLEAT_KERNEL_SET_SCALAR; set <= PLEAT_KERNEL_SET_AVX512; ++set )
		{
			plKernels k;
			if ( plChooseKernels( &k, (plKernelSet)set ) != (plKernelSet)set )
			{
				break;
			}
			sets.single[sets.count] = k;
			sets.batch[sets.count] = *k.batch;
			if ( set == PLEAT_KERNEL_SET_AVX512 )
			{
				assert_non_null( strstr( sets.batch[sets.count].isa, "avx512" ) );
			}
			sets.count++;
		}
		print_message( "batched kernel sets tested:" );
		for ( uint32_t i = 0; i < sets.count; ++i )
		{
			print_message( " %s", sets.batch[i].isa );
		}
		print_message( "\n" );
	}
	*state = &sets;
	return 0;
}
#define PLEAT_TEST_WITH_SETS( test ) cmocka_unit_test_setup( test, plKernelSets_Setup )

// A layer of random weights [out][in] (w, and w16 its fp16 copy) and bias [out], in one allocation (free w).
typedef struct plRandomLayer
{
	float* w;
	float* bias;
	uint16_t* w16;
} plRandomLayer;

static plRandomLayer plRandomLayer_Make( uint32_t in, uint32_t out )
{
	size_t count = (size_t)in * out;
	plRandomLayer l;
	l.w = (float*)malloc( ( count + out ) * sizeof( float ) + count * sizeof( uint16_t ) );
	l.bias = l.w + count;
	l.w16 = (uint16_t*)( l.bias + out );
	for ( size_t i = 0; i < count; ++i )
	{
		l.w[i] = plRand();
		l.w16[i] = plFloatToHalf( l.w[i] );
	}
	for ( uint32_t i = 0; i < out; ++i )
	{
		l.bias[i] = plRand();
	}
	return l;
}

static void test_mat_mat_equals_mat_vec_per_instance( void** state )
{
	const plTestSets* k = (const plTestSets*)*state;
	const uint32_t ins[] = { 1, 7, 8, 9, 15, 16, 17, 31, 33, 128, 681, 1030 };
	const uint32_t outs[] = { 1, 2, 3, 5, 8, 13, 64 };
	const uint32_t batches[] = { 1, 2, 3, 4, 5, 6, 7, 13, PLEAT_BATCH_MAX };
	for ( uint32_t s = 0; s < k->count; ++s )
	{
		for ( int fp16 = 0; fp16 < 2; ++fp16 )
		{
			for ( size_t a = 0; a < sizeof( ins ) / sizeof( ins[0] ); ++a )
			{
				for ( size_t o = 0; o < sizeof( outs ) / sizeof( outs[0] ); ++o )
				{
					uint32_t in = ins[a], out = outs[o];
					plRandomLayer layer = plRandomLayer_Make( in, out );
					const void* weights = fp16 ? (const void*)layer.w16 : (const void*)layer.w;
					for ( size_t bi = 0; bi < sizeof( batches ) / sizeof( batches[0] ); ++bi )
					{
						uint32_t n = batches[bi];
						float* xs = (float*)malloc( (size_t)n * in * sizeof( float ) );
						float* ys = (float*)malloc( (size_t)n * out * sizeof( float ) );
						float* single = (float*)malloc( out * sizeof( float ) );
						const float* x[PLEAT_BATCH_MAX];
						float* y[PLEAT_BATCH_MAX];
						for ( uint32_t b = 0; b < n; ++b )
						{
							for ( uint32_t c = 0; c < in; ++c )
							{
								xs[(size_t)b * in + c] = plRand() * 3.0f;
							}
							x[b] = xs + (size_t)b * in;
							y[b] = ys + (size_t)b * out;
						}
						// A row range starting at an odd row, as a worker would get.
						uint32_t begin = out > 3 ? 1 : 0;
						k->batch[s].mat_mat( y, x, n, weights, fp16, layer.bias, in, 0, in, begin, out );
						for ( uint32_t b = 0; b < n; ++b )
						{
							k->single[s].mat_vec( single, x[b], weights, fp16, layer.bias, in, 0, in, begin, out );
							assert_memory_equal( single + begin, y[b] + begin, ( out - begin ) * sizeof( float ) );
						}
						free( xs );
						free( ys );
						free( single );
					}
					free( layer.w );
				}
			}
		}
	}
}

// Every SIMD set's batched mat-mat (AVX2, AVX-512) against the scalar specification.
static void test_mat_mat_simd_within_rounding_of_scalar_spec( void** state )
{
	const plTestSets* k = (const plTestSets*)*state;
	if ( k->count < 2 )
	{
		skip();
	}
	const uint32_t in = 681, out = 37, n = 7;
	plRandomLayer layer = plRandomLayer_Make( in, out );
	const float *w = layer.w, *bias = layer.bias;
	float xs[7 * 681], ys[7 * 37], yv[7 * 37];
	const float* x[7];
	float *y_scalar[7], *y_simd[7];
	for ( uint32_t b = 0; b < n; ++b )
	{
		for ( uint32_t c = 0; c < in; ++c )
		{
			xs[b * in + c] = plRand() * 3.0f;
		}
		x[b] = xs + b * in;
		y_scalar[b] = ys + b * out;
		y_simd[b] = yv + b * out;
	}
	k->batch[0].mat_mat( y_scalar, x, n, w, 0, bias, in, 0, in, 0, out );
	for ( uint32_t s = 1; s < k->count; ++s )
	{
		k->batch[s].mat_mat( y_simd, x, n, w, 0, bias, in, 0, in, 0, out );
		for ( uint32_t b = 0; b < n; ++b )
		{
			for ( uint32_t r = 0; r < out; ++r )
			{
				double magnitude = fabs( bias[r] );
				for ( uint32_t c = 0; c < in; ++c )
				{
					magnitude += fabs( (double)w[(size_t)r * in + c] * x[b][c] );
				}
				assert_true( fabs( (double)y_scalar[b][r] - y_simd[b][r] ) <= 4.0 * in * 6e-8 * magnitude + 1e-30 );
			}
		}
	}
	free( layer.w );
}

// The lanes form of the mat-mat (sixteen instances per vector, where the set has one) against the single-instance
// mat-vec of the same set for every instance, bit for bit: 16-wide steps, the 8-wide step, scalar tails, row tiles
// of 3 and the rows left over, a partial lane group, fp32 and fp16, every column or a window of them (in place and
// packed).
static void test_mat_mat_lanes_equals_mat_vec_per_instance( void** state )
{
	const plTestSets* k = (const plTestSets*)*state;
	uint32_t tested = 0;
	const uint32_t ins[] = { 1, 7, 8, 9, 15, 16, 17, 33, 128, 681 };
	const uint32_t outs[] = { 1, 2, 3, 5, 64 };
	const uint32_t n = 21, groups = ( n + PLEAT_LANES - 1 ) / PLEAT_LANES;
	for ( uint32_t s = 0; s < k->count; ++s )
	{
		if ( k->batch[s].mat_mat_lanes == NULL )
		{
			continue;
		}
		tested++;
		for ( int fp16 = 0; fp16 < 2; ++fp16 )
		{
			for ( size_t a = 0; a < sizeof( ins ) / sizeof( ins[0] ); ++a )
			{
				for ( size_t o = 0; o < sizeof( outs ) / sizeof( outs[0] ); ++o )
				{
					uint32_t in = ins[a], out = outs[o];
					plRandomLayer layer = plRandomLayer_Make( in, out );
					float* xs = (float*)malloc( (size_t)n * in * sizeof( float ) );
					float* xt = (float*)aligned_alloc( 64, (size_t)groups * in * PLEAT_LANES * sizeof( float ) );
					float* yt = (float*)aligned_alloc( 64, (size_t)groups * out * PLEAT_LANES * sizeof( float ) );
					float* single = (float*)malloc( out * sizeof( float ) );
					for ( uint32_t g = 0; g < groups; ++g )
					{
						for ( uint32_t l = 0; l < PLEAT_LANES; ++l )
						{
							uint32_t b = g * PLEAT_LANES + l;
							for ( uint32_t c = 0; c < in; ++c )
							{
								float v = b < n ? plRand() * 3.0f : 0.0f;
								if ( b < n )
								{
									xs[(size_t)b * in + c] = v;
								}
								xt[( (size_t)g * in + c ) * PLEAT_LANES + l] = v;
							}
						}
					}
					const void* weights = fp16 ? (const void*)layer.w16 : (const void*)layer.w;
					size_t element = fp16 ? 2 : 4;
					uint32_t begin = out > 3 ? 1 : 0; // a row range starting at an odd row, as a worker gets
					// every column; a window [cb, in) read in place; the same window from a packed copy
					// ([out][in - cb], as plPackLayer makes): all three against the single job's mat-vec
					uint32_t cb = in / 3;
					char* packed = (char*)malloc( (size_t)out * ( in - cb ) * element );
					for ( uint32_t r = 0; r < out; ++r )
					{
						memcpy( packed + (size_t)r * ( in - cb ) * element,
								(const char*)weights + ( (size_t)r * in + cb ) * element, ( in - cb ) * element );
					}
					for ( int form = 0; form < 3; ++form )
					{
						uint32_t col = form == 0 ? 0 : cb;
						const void* window = form == 2 ? (const void*)packed
													   : (const void*)( (const char*)weights + col * element );
						size_t stride = form == 2 ? in - cb : in;
						k->batch[s].mat_mat_lanes( yt, xt, groups, window, stride, fp16, layer.bias, in, out, col, in,
												   begin, out );
						for ( uint32_t b = 0; b < n; ++b )
						{
							k->single[s].mat_vec( single, xs + (size_t)b * in, weights, fp16, layer.bias, in, col, in,
												  begin, out );
							for ( uint32_t r = begin; r < out; ++r )
							{
								float lane =
									yt[( (size_t)( b / PLEAT_LANES ) * out + r ) * PLEAT_LANES + b % PLEAT_LANES];
								assert_memory_equal( &single[r], &lane, sizeof( float ) );
							}
						}
					}
					free( packed );
					free( layer.w );
					free( xs );
					free( xt );
					free( yt );
					free( single );
				}
			}
		}
	}
	if ( tested == 0 )
	{
		skip(); // no lanes kernel on this CPU (AVX-512 only)
	}
}

static void test_blend_batch_equals_blend_per_instance( void** state )
{
	const plTestSets* k = (const plTestSets*)*state;
	const uint32_t vertex_counts[] = { 1, 3, 5, 6, 11, 16, 17, 33, 100, 1004 };
	const uint32_t blend_counts[] = { 1, 3, 4, 5, 9, 32, 130 };
	const uint32_t batches[] = { 1, 3, 4, 5, 8, 9, 17, PLEAT_BATCH_MAX };
	for ( uint32_t s = 0; s < k->count; ++s )
	{
		for ( int type = PLEAT_SHAPES_F32; type <= PLEAT_SHAPES_I8; ++type )
		{
			for ( size_t vi = 0; vi < sizeof( vertex_counts ) / sizeof( vertex_counts[0] ); ++vi )
			{
				for ( size_t di = 0; di < sizeof( blend_counts ) / sizeof( blend_counts[0] ); ++di )
				{
					uint32_t nv = vertex_counts[vi], d = blend_counts[di];
					size_t plane = (size_t)nv * 3;
					plTestShapes shapes = plTestShapes_Make( type, d, plane, 0.01f, plRand );
					const plBlendShapes* sh = &shapes.shapes;
					for ( size_t bi = 0; bi < sizeof( batches ) / sizeof( batches[0] ); ++bi )
					{
						uint32_t n = batches[bi];
						float* bases = (float*)malloc( n * plane * sizeof( float ) );
						float* outs = (float*)malloc( n * plane * sizeof( float ) );
						float* ws = (float*)malloc( (size_t)n * d * sizeof( float ) );
						float* single = (float*)malloc( plane * sizeof( float ) );
						const float *base[PLEAT_BATCH_MAX], *weights[PLEAT_BATCH_MAX];
						float* out[PLEAT_BATCH_MAX];
						for ( uint32_t b = 0; b < n; ++b )
						{
							for ( size_t i = 0; i < plane; ++i )
							{
								bases[b * plane + i] = plRand();
								outs[b * plane + i] = -7.0f; // outside the range: must stay untouched
							}
							for ( uint32_t j = 0; j < d; ++j )
							{
								ws[(size_t)b * d + j] = 2.0f * plRand();
							}
							base[b] = bases + b * plane;
							out[b] = outs + b * plane;
							weights[b] = ws + (size_t)b * d;
						}
						// A vertex range not starting at 0, as a worker would get (when there is more than one).
						uint32_t begin = nv > 2 ? 1 : 0, end = nv;
						k->batch[s].blend_shapes_batch( out, base, weights, n, sh, d, nv, begin, end );
						for ( uint32_t b = 0; b < n; ++b )
						{
							k->single[s].blend_shapes( single, base[b], sh, weights[b], d, nv, begin, end );
							assert_memory_equal( single + begin * 3, out[b] + begin * 3,
												 ( end - begin ) * 3 * sizeof( float ) );
							for ( size_t i = 0; i < (size_t)begin * 3; ++i )
							{
								assert_true( out[b][i] == -7.0f );
							}
						}
						free( bases );
						free( outs );
						free( ws );
						free( single );
					}
					plTestShapes_Free( &shapes );
				}
			}
		}
	}
}

// The jobs: f_LP-like chains through plMlpBatchJob against plMlpJob per instance (the hidden layers in each instance's
// own scratch), with the rows split over workers, and a table of invalid jobs.
typedef struct plTestNet
{
	plLayer layers[3];
	float* storage;
} plTestNet;

static void plTestNet_Init( plTestNet* net, const uint32_t widths[4], int fp16 )
{
	memset( net->layers, 0, sizeof( net->layers ) ); // block_count 0: dense
	size_t total = 0;
	for ( int l = 0; l < 3; ++l )
	{
		total += (size_t)widths[l] * widths[l + 1] + widths[l + 1];
	}
	net->storage = (float*)malloc( total * sizeof( float ) * 2 );
	float* p = net->storage;
	for ( int l = 0; l < 3; ++l )
	{
		size_t count = (size_t)widths[l] * widths[l + 1];
		float* w = p;
		uint16_t* w16 = (uint16_t*)( p + count );
		for ( size_t i = 0; i < count; ++i )
		{
			w[i] = plRand() / sqrtf( (float)widths[l] );
			w16[i] = plFloatToHalf( w[i] );
		}
		p += count + ( count + 1 ) / 2;
		float* bias = p;
		for ( uint32_t i = 0; i < widths[l + 1]; ++i )
		{
			bias[i] = 0.1f * plRand();
		}
		p += widths[l + 1];
		net->layers[l].weight = fp16 ? (const void*)w16 : (const void*)w;
		net->layers[l].weight_fp16 = fp16;
		net->layers[l].bias = bias;
		net->layers[l].in_count = widths[l];
		net->layers[l].out_count = widths[l + 1];
	}
}

static void test_mlp_batch_job_equals_mlp_job_per_instance( void** state )
{
	const plTestSets* k = (const plTestSets*)*state;
	const uint32_t widths[4] = { 681 % 200 + 3, 130, 70, 19 };
	enum
	{
		N = 21 // two lane groups of the lanes form, the second partial
	};
	for ( uint32_t s = 0; s < k->count; ++s )
	{
		for ( int fp16 = 0; fp16 < 2; ++fp16 )
		{
			for ( uint32_t activation = PLEAT_ACTIVATION_RELU; activation <= PLEAT_ACTIVATION_SILU; ++activation )
			{
				plTestNet net;
				plTestNet_Init( &net, widths, fp16 );
				static float xs[N][256], ys[N][32], scratch[N][2 * 130], single[32], single_scratch[2 * 130];
				plConstSpan inputs[N];
				plSpan outputs[N], scratches[N];
				for ( uint32_t b = 0; b < N; ++b )
				{
					for ( uint32_t c = 0; c < widths[0]; ++c )
					{
						xs[b][c] = plRand();
					}
					inputs[b] = plMakeConstSpan( xs[b], widths[0], 4 );
					outputs[b] = plMakeSpan( ys[b], widths[3], 4 );
					scratches[b] = plMakeSpan( scratch[b], 2 * 130, 4 );
				}
				// With lanes scratch (the transposed chain, where the set has a lanes kernel) and without.
				size_t lanes_floats = plMlpBatchLanesFloats( net.layers, 3, N );
				float* lanes = (float*)aligned_alloc( 64, ( lanes_floats * sizeof( float ) + 63 ) & ~(size_t)63 );
				for ( int use_lanes = 0; use_lanes < 2; ++use_lanes )
				{
					plMlpBatchJob job = { net.layers, 3, activation, N, inputs, outputs, scratches, &k->batch[s], NULL,
										  use_lanes ? lanes : NULL, use_lanes ? lanes_floats : 0, k->single[s].mat_vec_int8,
										  k->single[s].mat_mat_int8, k->single[s].quantise_int8 };
					memset( ys, 0, sizeof( ys ) );
					assert_int_equal( plMlpBatchJob_Run( &job ), PLEAT_RESULT_OK );
					for ( uint32_t b = 0; b < N; ++b )
					{
						plMlpJob one = { net.layers,
										 3,
										 activation,
										 inputs[b],
										 plMakeSpan( single, widths[3], 4 ),
										 plMakeSpan( single_scratch, 2 * 130, 4 ),
										 &k->single[s],
										 NULL };
						assert_int_equal( plMlpJob_Run( &one ), PLEAT_RESULT_OK );
						assert_memory_equal( single, ys[b], widths[3] * sizeof( float ) );
					}
				}
				free( lanes );
				plMlpBatchJob job = {
					net.layers, 3, activation, N, inputs, outputs, scratches, &k->batch[s], NULL, NULL, 0, NULL, NULL, NULL };

				// Invalid jobs are rejected before anything is written.
				plMlpBatchJob bad = job;
				bad.batch_count = 0;
				assert_int_equal( plMlpBatchJob_Run( &bad ), PLEAT_RESULT_INVALID_ARGUMENT );
				PLEAT_EXPECT_INVALID( plMlpBatchJob, job, batch_count, PLEAT_BATCH_MAX + 1 );
				PLEAT_EXPECT_INVALID( plMlpBatchJob, job, activation, 7 );
				PLEAT_EXPECT_INVALID( plMlpBatchJob, job, kernels, NULL );
				plSpan short_scratch[N];
				memcpy( short_scratch, scratches, sizeof( scratches ) );
				short_scratch[N - 1] = plMakeSpan( scratch[N - 1], 2 * 130 - 1, 4 );
				PLEAT_EXPECT_INVALID( plMlpBatchJob, job, scratch, short_scratch );
				plConstSpan short_inputs[N];
				memcpy( short_inputs, inputs, sizeof( inputs ) );
				short_inputs[3] = plMakeConstSpan( xs[3], widths[0] - 1, 4 );
				PLEAT_EXPECT_INVALID( plMlpBatchJob, job, inputs, short_inputs );
				free( net.storage );
			}
		}
	}
}

static void test_blend_batch_job_rejects_bad_spans( void** state )
{
	(void)state;
	plKernels k;
	plChooseKernels( &k, PLEAT_KERNEL_SET_SCALAR );
	plBatchKernels bk = *k.batch;
	static float shapes[4 * 10 * 3], base[2][30], out[2][30], w[2][4];
	plConstSpan bases[2] = { plMakeConstSpan( base[0], 10, 12 ), plMakeConstSpan( base[1], 10, 12 ) };
	plConstSpan weights[2] = { plMakeConstSpan( w[0], 4, 4 ), plMakeConstSpan( w[1], 4, 4 ) };
	plSpan outs[2] = { plMakeSpan( out[0], 10, 12 ), plMakeSpan( out[1], 10, 12 ) };
	plBlendShapesBatchJob job = { 2, bases, weights, outs, { shapes, PLEAT_SHAPES_F32, NULL }, 10, 0, 10, &bk };
	assert_int_equal( plBlendShapesBatchJob_Run( &job ), PLEAT_RESULT_OK );
	plBlendShapesBatchJob bad = job;
	bad.vertex_end = 11;
	assert_int_equal( plBlendShapesBatchJob_Run( &bad ), PLEAT_RESULT_INVALID_ARGUMENT );
	bad = job;
	bad.vertex_begin = 5;
	bad.vertex_end = 4;
	assert_false( plBlendShapesBatchJob_Validate( &bad ) );
	plConstSpan mixed[2] = { plMakeConstSpan( w[0], 4, 4 ), plMakeConstSpan( w[1], 3, 4 ) };
	PLEAT_EXPECT_INVALID( plBlendShapesBatchJob, job, weights, mixed );
	plSpan aliased[2] = { plMakeSpan( base[0], 10, 12 ), plMakeSpan( out[1], 10, 12 ) };
	PLEAT_EXPECT_INVALID( plBlendShapesBatchJob, job, outputs, aliased );
	PLEAT_EXPECT_INVALID( plBlendShapesBatchJob, job, batch_count, 0 );
	PLEAT_EXPECT_INVALID( plBlendShapesBatchJob, job, blend_shapes.data, NULL );
	PLEAT_EXPECT_INVALID( plBlendShapesBatchJob, job, blend_shapes.type, 3 ); // no such storage
}

// Skinning: each instance of a batch gets what the single-instance kernel of the same set gives it, bit for bit — lane
// groups full and ragged, vertex ranges that end inside a block of lanes, 1..8 influences, a joint index out of range
// (weight 0) — and the SIMD sets stay within rounding of the scalar specification.
static void plFillSkin( uint32_t n, uint32_t K, uint32_t J, uint16_t* indices, float* weights )
{
	for ( uint32_t v = 0; v < n; ++v )
	{
		float total = 0.0f;
		for ( uint32_t k = 0; k < K; ++k )
		{
			indices[v * K + k] = (uint16_t)( ( v * 7u + k * 5u ) % ( J + 1u ) ); // J itself: out of range
			weights[v * K + k] = 0.5f + 0.5f * plRand();
			total += weights[v * K + k];
		}
		for ( uint32_t k = 0; k < K; ++k )
		{
			weights[v * K + k] /= total;
		}
	}
}

static void test_skinning_batch_equals_skinning_per_instance( void** state )
{
	const plTestSets* k = (const plTestSets*)*state;
	const uint32_t vertex_counts[] = { 1, 7, 8, 9, 23, 100 };
	const uint32_t batches[] = { 1, 3, 8, 9, 17, PLEAT_BATCH_MAX };
	const uint32_t J = 24;
	for ( uint32_t s = 0; s < k->count; ++s )
	{
		for ( uint32_t K = 1; K <= 8; K += ( K < 4 ? 1 : 4 ) )
		{
			for ( size_t vi = 0; vi < sizeof( vertex_counts ) / sizeof( vertex_counts[0] ); ++vi )
			{
				uint32_t nv = vertex_counts[vi];
				uint16_t* indices = (uint16_t*)malloc( (size_t)nv * K * sizeof( uint16_t ) );
				float* weights = (float*)malloc( (size_t)nv * K * sizeof( float ) );
				plFillSkin( nv, K, J, indices, weights );
				float* single = (float*)malloc( (size_t)nv * 3 * sizeof( float ) );
				for ( size_t bi = 0; bi < sizeof( batches ) / sizeof( batches[0] ); ++bi )
				{
					uint32_t n = batches[bi];
					float* ins = (float*)malloc( (size_t)n * nv * 3 * sizeof( float ) );
					float* outs = (float*)malloc( (size_t)n * nv * 3 * sizeof( float ) );
					float* mats = (float*)malloc( (size_t)n * J * 12 * sizeof( float ) );
					const float *in[PLEAT_BATCH_MAX], *m[PLEAT_BATCH_MAX];
					float* out[PLEAT_BATCH_MAX];
					for ( uint32_t b = 0; b < n; ++b )
					{
						for ( size_t i = 0; i < (size_t)nv * 3; ++i )
						{
							ins[b * nv * 3 + i] = plRand();
							outs[b * nv * 3 + i] = -7.0f; // outside the range: must stay untouched
						}
						for ( uint32_t e = 0; e < J * 12; ++e )
						{
							mats[(size_t)b * J * 12 + e] = 2.0f * plRand();
						}
						in[b] = ins + (size_t)b * nv * 3;
						out[b] = outs + (size_t)b * nv * 3;
						m[b] = mats + (size_t)b * J * 12;
					}
					uint32_t begin = nv > 2 ? 1 : 0, end = nv > 8 ? nv - 1 : nv;
					k->batch[s].skinning_batch( out, in, n, indices, weights, K, m, J, begin, end );
					// the single kernel as the step runs it: with the asset's column offsets
					uint32_t* columns = (uint32_t*)malloc( (size_t)nv * K * sizeof( uint32_t ) );
					plSkinColumnOffsets( columns, indices, (size_t)nv * K, J );
					for ( uint32_t b = 0; b < n; ++b )
					{
						for ( size_t i = 0; i < (size_t)nv * 3; ++i )
						{
							single[i] = -7.0f;
						}
						k->single[s].skinning( single, 12, in[b], 12, indices, weights, K, columns, m[b], J, begin,
											   end );
						assert_memory_equal( single, out[b], (size_t)nv * 3 * sizeof( float ) );
						if ( s > 0 )
						{
							plSkinning_Scalar( single, 12, in[b], 12, indices, weights, K, NULL, m[b], J, begin, end );
							for ( size_t i = (size_t)begin * 3; i < (size_t)end * 3; ++i )
							{
								assert_true( fabsf( single[i] - out[b][i] ) <= 1e-5f * ( 1.0f + fabsf( single[i] ) ) );
							}
						}
					}
					free( columns );
					free( ins );
					free( outs );
					free( mats );
				}
				free( single );
				free( indices );
				free( weights );
			}
		}
	}
}

// A strip of quads, faces in ascending order, plus a degenerate (zero-area) face and a face with an index out of
// range (a zero normal for its in-range vertices, as the single kernels do).
static uint32_t plStripMesh( uint32_t columns, uint32_t* faces )
{
	uint32_t f = 0;
	for ( uint32_t c = 0; c + 1 < columns; ++c )
	{
		uint32_t a = c, b = c + 1, d = columns + c, e = columns + c + 1;
		faces[3 * f] = a, faces[3 * f + 1] = b, faces[3 * f + 2] = d, ++f;
		faces[3 * f] = b, faces[3 * f + 1] = e, faces[3 * f + 2] = d, ++f;
	}
	faces[3 * f] = 0, faces[3 * f + 1] = 0, faces[3 * f + 2] = 1, ++f;
	faces[3 * f] = 1, faces[3 * f + 1] = 2 * columns + 5, faces[3 * f + 2] = 2, ++f;
	return f;
}

static void test_normals_batch_equals_scatter_per_instance( void** state )
{
	const plTestSets* k = (const plTestSets*)*state;
	const uint32_t column_counts[] = { 2, 4, 5, 12, 50 };
	const uint32_t batches[] = { 1, 3, 8, 9, 17, PLEAT_BATCH_MAX };
	for ( uint32_t s = 0; s < k->count; ++s )
	{
		for ( size_t ci = 0; ci < sizeof( column_counts ) / sizeof( column_counts[0] ); ++ci )
		{
			uint32_t columns = column_counts[ci], nv = 2 * columns;
			uint32_t* faces = (uint32_t*)malloc( (size_t)( 2 * columns + 2 ) * 3 * sizeof( uint32_t ) );
			uint32_t nf = plStripMesh( columns, faces );
			float* scratch = (float*)aligned_alloc(
				64,
				( plNormalsBatchScratchFloats( nv, k->batch[s].geometry_lanes ) * sizeof( float ) + 63 ) & ~(size_t)63 );
			float* sums4 = (float*)aligned_alloc( 64, ( (size_t)nv * 16 + 127 ) & ~(size_t)63 ); // a multiple of 64 (C11)
			for ( size_t bi = 0; bi < sizeof( batches ) / sizeof( batches[0] ); ++bi )
			{
				uint32_t n = batches[bi];
				float* ps = (float*)malloc( (size_t)n * nv * 3 * sizeof( float ) );
				float* ns = (float*)malloc( (size_t)n * nv * 3 * sizeof( float ) );
				float* single = (float*)malloc( (size_t)nv * 3 * sizeof( float ) );
				const float* p[PLEAT_BATCH_MAX];
				float* nrm[PLEAT_BATCH_MAX];
				for ( uint32_t b = 0; b < n; ++b )
				{
					for ( size_t i = 0; i < (size_t)nv * 3; ++i )
					{
						ps[b * nv * 3 + i] = ( b % 5 == 4 ) ? 0.0f : plRand(); // every fifth: all zero-area faces
					}
					p[b] = ps + (size_t)b * nv * 3;
					nrm[b] = ns + (size_t)b * nv * 3;
				}
				k->batch[s].normals_batch( nrm, p, n, nv, faces, nf, scratch );
				for ( uint32_t b = 0; b < n; ++b )
				{
					k->single[s].normals_scatter( single, 12, p[b], 12, nv, faces, nf, sums4 );
					assert_memory_equal( single, nrm[b], (size_t)nv * 3 * sizeof( float ) );
					if ( s > 0 )
					{
						plNormalsScatter_Scalar( single, 12, p[b], 12, nv, faces, nf, sums4 );
						assert_memory_equal( single, nrm[b], (size_t)nv * 3 * sizeof( float ) ); // bit-identical too
					}
				}
				free( ps );
				free( ns );
				free( single );
			}
			free( faces );
			free( scratch );
			free( sums4 );
		}
	}
}

// The fast body contact: each instance of a batch (its own anchors, clearance and matrices) gets what the single-instance kernel
// of the same set gives it, bit for bit: vertices without an anchor, degenerate blended normals, vertices beyond the
// clearance (unchanged) and inside it (pushed), ragged lane groups and vertex ranges, 1..4 influences.
static void test_fast_body_contact_batch_equals_per_instance( void** state )
{
	const plTestSets* k = (const plTestSets*)*state;
	const uint32_t vertex_counts[] = { 1, 7, 9, 23, 100 };
	const uint32_t batches[] = { 1, 3, 8, 9, 17 };
	const uint32_t J = 24;
	for ( uint32_t s = 0; s < k->count; ++s )
	{
		for ( uint32_t K = 1; K <= 4; ++K )
		{
			for ( size_t vi = 0; vi < sizeof( vertex_counts ) / sizeof( vertex_counts[0] ); ++vi )
			{
				uint32_t nv = vertex_counts[vi];
				uint16_t* indices = (uint16_t*)malloc( (size_t)nv * K * sizeof( uint16_t ) );
				float* weights = (float*)malloc( (size_t)nv * K * sizeof( float ) );
				float* normals = (float*)malloc( (size_t)nv * 3 * sizeof( float ) );
				plFillSkin( nv, K, J, indices, weights );
				for ( uint32_t v = 0; v < nv; ++v )
				{
					float x = plRand(), y = plRand(), z = plRand(), l = sqrtf( x * x + y * y + z * z ) + 1e-3f;
					int none = v % 5 == 3; // no anchor
					normals[3 * v] = none ? 0.0f : x / l;
					normals[3 * v + 1] = none ? 0.0f : y / l;
					normals[3 * v + 2] = none ? 0.0f : z / l;
				}
				for ( size_t bi = 0; bi < sizeof( batches ) / sizeof( batches[0] ); ++bi )
				{
					uint32_t n = batches[bi];
					float* ps = (float*)malloc( (size_t)n * nv * 3 * sizeof( float ) );
					float* anchors = (float*)malloc( (size_t)n * nv * 3 * sizeof( float ) );
					float* mats = (float*)malloc( (size_t)n * J * 12 * sizeof( float ) );
					float* single = (float*)malloc( (size_t)nv * 3 * sizeof( float ) );
					float offsets[PLEAT_BATCH_MAX];
					float* p[PLEAT_BATCH_MAX];
					const float *r[PLEAT_BATCH_MAX], *m[PLEAT_BATCH_MAX];
					for ( uint32_t b = 0; b < n; ++b )
					{
						for ( uint32_t e = 0; e < J * 12; ++e )
						{
							// near a rigid pose (the identity plus noise), all zero for one joint: its vertices blend
							// a degenerate normal when all their influences name it
							float identity = ( e % 12 == 0 || e % 12 == 5 || e % 12 == 10 ) ? 1.0f : 0.0f;
							mats[(size_t)b * J * 12 + e] = e / 12 == 7 ? 0.0f : identity + 0.05f * plRand();
						}
						for ( size_t i = 0; i < (size_t)nv * 3; ++i )
						{
							anchors[(size_t)b * nv * 3 + i] = 0.1f * plRand();
							ps[(size_t)b * nv * 3 + i] = anchors[(size_t)b * nv * 3 + i] + 0.01f * plRand();
						}
						offsets[b] = 0.002f + 0.001f * (float)( b % 3 );
						p[b] = ps + (size_t)b * nv * 3;
						r[b] = anchors + (size_t)b * nv * 3;
						m[b] = mats + (size_t)b * J * 12;
					}
					float* before = (float*)malloc( (size_t)n * nv * 3 * sizeof( float ) );
					memcpy( before, ps, (size_t)n * nv * 3 * sizeof( float ) );
					uint32_t begin = nv > 2 ? 1 : 0, end = nv > 8 ? nv - 1 : nv;
					k->batch[s].body_contact_fast_batch( p, r, offsets, n, normals, indices, weights, K, m, J, begin, end );
					uint32_t* columns = (uint32_t*)malloc( (size_t)nv * K * sizeof( uint32_t ) );
					plSkinColumnOffsets( columns, indices, (size_t)nv * K, J );
					int moved = 0;
					for ( uint32_t b = 0; b < n; ++b )
					{
						memcpy( single, before + (size_t)b * nv * 3, (size_t)nv * 3 * sizeof( float ) );
						k->single[s].body_contact_fast( single, 12, r[b], normals, indices, weights, K, columns, m[b], J,
													   offsets[b], begin, end );
						assert_memory_equal( single, p[b], (size_t)nv * 3 * sizeof( float ) );
						moved |= memcmp( single, before + (size_t)b * nv * 3, (size_t)nv * 3 * sizeof( float ) ) != 0;
					}
					assert_true( moved || nv * n < 50 ); // the comparison means something: contact moved vertices
					free( ps );
					free( anchors );
					free( mats );
					free( single );
					free( before );
					free( columns );
				}
				free( indices );
				free( weights );
				free( normals );
			}
		}
	}
}

// The full body contact in lanes: each of up to 8 instances (its own points of β, matrices and clearance) gets what the
// single kernels of the same set give it — posing, ring normals, push — bit for bit: points without a normal (ring
// corners), points with and without rings, candidates with empty slots and indices past P, vertices without
// candidates, a joint whose matrix is zero (degenerate normals), batches of 1 to 8.
static void test_full_body_contact_batch_equals_per_instance( void** state )
{
	const plTestSets* k = (const plTestSets*)*state;
	enum { J = 24, K = 4, P = 67, NV = 41, C = 3, R = 6 };
	uint16_t indices[P * K], candidates[NV * C], rings[P * R];
	float weights[P * K], normals[P * 3];
	plFillSkin( P, K, J, indices, weights );
	for ( uint32_t q = 0; q < P; ++q )
	{
		float x = plRand(), y = plRand(), z = plRand(), l = sqrtf( x * x + y * y + z * z ) + 1e-3f;
		int corner = q % 6 == 5;
		normals[3 * q] = corner ? 0.0f : x / l;
		normals[3 * q + 1] = corner ? 0.0f : y / l;
		normals[3 * q + 2] = corner ? 0.0f : z / l;
		uint32_t m = q % 4 == 1 ? 0 : 3 + q % 4; // no ring, or 3..6 points around
		for ( uint32_t i = 0; i < R; ++i )
		{
			rings[q * R + i] = i < m ? (uint16_t)( ( q * 5 + i * 7 + 1 ) % P ) : PLEAT_NO_CONTACT_CANDIDATE;
		}
	}
	for ( uint32_t v = 0; v < NV; ++v )
	{
		for ( uint32_t c = 0; c < C; ++c )
		{
			uint32_t q = ( v * 3 + c * 11 ) % P;
			candidates[v * C + c] = v % 9 == 4 ? PLEAT_NO_CONTACT_CANDIDATE
									: c == 2 && v % 4 == 0 ? (uint16_t)( P + v ) : (uint16_t)q;
		}
	}
	_Alignas( 32 ) int32_t ring_lanes[( P + 7 ) / 8 * R * 8]; // the single step's rings in lanes, as the asset has them
	plRingLanes( ring_lanes, rings, R, P );
	uint32_t row_offsets[( NV + 7 ) / 8 * C * 8]; // and its candidates as posed rows' offsets
	plContactRowOffsets( row_offsets, candidates, C, NV, P );
	uint32_t column_offsets[P * K]; // and its skin as column-block offsets
	plSkinColumnOffsets( column_offsets, indices, (size_t)P * K, J );
	// (a machine without AVX2 has only the scalar set, which runs each instance alone: nothing to compare)
	for ( uint32_t s = 0; s < k->count; ++s )
	{
		if ( k->batch[s].body_contact_batch == NULL )
		{
			continue;
		}
		// every count up to the set's lane group (8 for AVX2, 16 for AVX-512), ragged ones included
		for ( uint32_t n = 1; n <= k->batch[s].geometry_lanes; n += 3 )
		{
			static float ps[16][NV * 3], before[16][NV * 3], points[16][P * 3], mats[16][J * 12], single[NV * 3];
			static float posed[( P + 1 ) * PLEAT_POSED_POINT_FLOATS]; // (row P zero: row offsets)
			static _Alignas( 64 ) float scratch[P * 8 * 16];
			float offsets[16];
			float* pp[16];
			const float *rr[16], *mm[16];
			for ( uint32_t b = 0; b < n; ++b )
			{
				for ( uint32_t e = 0; e < J * 12; ++e )
				{
					float identity = ( e % 12 == 0 || e % 12 == 5 || e % 12 == 10 ) ? 1.0f : 0.0f;
					mats[b][e] = e / 12 == 7 ? 0.0f : identity + 0.05f * plRand();
				}
				for ( uint32_t i = 0; i < P * 3; ++i )
				{
					points[b][i] = 0.1f * plRand();
				}
				for ( uint32_t v = 0; v < NV; ++v )
				{
					for ( int e = 0; e < 3; ++e )
					{
						ps[b][v * 3 + e] = points[b][( ( v * 3 ) % P ) * 3 + e] + 0.01f * plRand();
					}
				}
				offsets[b] = 0.002f + 0.001f * (float)( b % 3 );
				pp[b] = ps[b];
				rr[b] = points[b];
				mm[b] = mats[b];
			}
			memcpy( before, ps, sizeof( before ) );
			k->batch[s].body_contact_batch( pp, rr, offsets, n, normals, indices, weights, K, mm, J, P, candidates, C,
											 rings, R, NV, scratch );
			int moved = 0;
			for ( uint32_t b = 0; b < n; ++b )
			{
				memcpy( single, before[b], sizeof( single ) );
				k->single[s].pose_body_points( posed, points[b], normals, indices, weights, K, column_offsets, mats[b], J,
											   rings, R, P, 0,
											  P );
				k->single[s].body_point_normals( posed, P, rings, R, ring_lanes, 0, P );
				k->single[s].body_contact( single, 12, posed, P, candidates, C, row_offsets, offsets[b], 0, NV );
				assert_memory_equal( single, ps[b], sizeof( single ) );
				moved |= memcmp( single, before[b], sizeof( single ) ) != 0;
			}
			assert_true( moved );
		}
	}
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		PLEAT_TEST_WITH_SETS( test_fast_body_contact_batch_equals_per_instance ),
		PLEAT_TEST_WITH_SETS( test_full_body_contact_batch_equals_per_instance ),
		PLEAT_TEST_WITH_SETS( test_mat_mat_equals_mat_vec_per_instance ),
		PLEAT_TEST_WITH_SETS( test_mat_mat_simd_within_rounding_of_scalar_spec ),
		PLEAT_TEST_WITH_SETS( test_mat_mat_lanes_equals_mat_vec_per_instance ),
		PLEAT_TEST_WITH_SETS( test_blend_batch_equals_blend_per_instance ),
		PLEAT_TEST_WITH_SETS( test_mlp_batch_job_equals_mlp_job_per_instance ),
		cmocka_unit_test( test_blend_batch_job_rejects_bad_spans ),
		PLEAT_TEST_WITH_SETS( test_skinning_batch_equals_skinning_per_instance ),
		PLEAT_TEST_WITH_SETS( test_normals_batch_equals_scatter_per_instance ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
