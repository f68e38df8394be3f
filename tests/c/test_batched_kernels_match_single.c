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
#include "test_common.h"

static uint32_t s_rng = 4242;

static float plRand( void )
{
	s_rng ^= s_rng << 13;
	s_rng ^= s_rng >> 17;
	s_rng ^= s_rng << 5;
	return (float)( s_rng >> 8 ) / 8388608.0f - 1.0f;
}

// The kernel sets to compare: scalar always, AVX2 when this build and CPU have it.
static uint32_t plKernelSets( plKernels sets[2], plBatchKernels batch[2] )
{
	uint32_t count = 0;
	for ( int scalar = 1; scalar >= 0; --scalar )
	{
		plKernels k;
		int avx2 = plSelectKernels( &k, scalar );
		if ( !scalar && !avx2 )
		{
			break;
		}
		sets[count] = k;
		assert_true( plSelectBatchKernels( &k, &batch[count] ) );
		count++;
	}
	return count;
}

static void test_mat_mat_equals_mat_vec_per_instance( void** state )
{
	(void)state;
	plKernels sets[2];
	plBatchKernels batch[2];
	uint32_t set_count = plKernelSets( sets, batch );
	const uint32_t ins[] = { 1, 7, 8, 9, 15, 16, 17, 31, 33, 128, 681 };
	const uint32_t outs[] = { 1, 2, 3, 5, 8, 13, 64 };
	const uint32_t batches[] = { 1, 2, 3, 4, 5, 7, PLEAT_BATCH_MAX };
	for ( uint32_t s = 0; s < set_count; ++s )
	{
		for ( int fp16 = 0; fp16 < 2; ++fp16 )
		{
			for ( size_t a = 0; a < sizeof( ins ) / sizeof( ins[0] ); ++a )
			{
				for ( size_t o = 0; o < sizeof( outs ) / sizeof( outs[0] ); ++o )
				{
					uint32_t in = ins[a], out = outs[o];
					float* w = (float*)malloc( (size_t)in * out * sizeof( float ) );
					uint16_t* w16 = (uint16_t*)malloc( (size_t)in * out * sizeof( uint16_t ) );
					float* bias = (float*)malloc( out * sizeof( float ) );
					for ( size_t i = 0; i < (size_t)in * out; ++i )
					{
						w[i] = plRand();
						w16[i] = plFloatToHalf( w[i] );
					}
					for ( uint32_t i = 0; i < out; ++i )
					{
						bias[i] = plRand();
					}
					const void* weights = fp16 ? (const void*)w16 : (const void*)w;
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
						batch[s].mat_mat( y, x, n, weights, fp16, bias, in, begin, out );
						for ( uint32_t b = 0; b < n; ++b )
						{
							sets[s].mat_vec( single, x[b], weights, fp16, bias, in, begin, out );
							assert_memory_equal( single + begin, y[b] + begin, ( out - begin ) * sizeof( float ) );
						}
						free( xs );
						free( ys );
						free( single );
					}
					free( w );
					free( w16 );
					free( bias );
				}
			}
		}
	}
}

static void test_mat_mat_avx2_within_rounding_of_scalar_spec( void** state )
{
	(void)state;
	plKernels sets[2];
	plBatchKernels batch[2];
	if ( plKernelSets( sets, batch ) < 2 )
	{
		skip();
	}
	const uint32_t in = 681, out = 37, n = 5;
	float* w = (float*)malloc( (size_t)in * out * sizeof( float ) );
	float bias[37], xs[5 * 681], ys[5 * 37], yv[5 * 37];
	for ( size_t i = 0; i < (size_t)in * out; ++i )
	{
		w[i] = plRand();
	}
	for ( uint32_t i = 0; i < out; ++i )
	{
		bias[i] = plRand();
	}
	const float* x[5];
	float *y_scalar[5], *y_simd[5];
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
	batch[0].mat_mat( y_scalar, x, n, w, 0, bias, in, 0, out );
	batch[1].mat_mat( y_simd, x, n, w, 0, bias, in, 0, out );
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
	free( w );
}

static void test_blend_batch_equals_blend_per_instance( void** state )
{
	(void)state;
	plKernels sets[2];
	plBatchKernels batch[2];
	uint32_t set_count = plKernelSets( sets, batch );
	const uint32_t vertex_counts[] = { 1, 3, 5, 6, 11, 100, 1004 };
	const uint32_t blend_counts[] = { 1, 3, 4, 5, 9, 32 };
	const uint32_t batches[] = { 1, 3, 4, 5, 9, PLEAT_BATCH_MAX };
	for ( uint32_t s = 0; s < set_count; ++s )
	{
		for ( int fp16 = 0; fp16 < 2; ++fp16 )
		{
			for ( size_t vi = 0; vi < sizeof( vertex_counts ) / sizeof( vertex_counts[0] ); ++vi )
			{
				for ( size_t di = 0; di < sizeof( blend_counts ) / sizeof( blend_counts[0] ); ++di )
				{
					uint32_t nv = vertex_counts[vi], d = blend_counts[di];
					size_t plane = (size_t)nv * 3;
					float* shapes = (float*)malloc( d * plane * sizeof( float ) );
					uint16_t* shapes16 = (uint16_t*)malloc( d * plane * sizeof( uint16_t ) );
					for ( size_t i = 0; i < d * plane; ++i )
					{
						shapes[i] = 0.01f * plRand();
						shapes16[i] = plFloatToHalf( shapes[i] );
					}
					const void* sh = fp16 ? (const void*)shapes16 : (const void*)shapes;
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
						batch[s].blend_shapes_batch( out, base, weights, n, sh, fp16, d, nv, begin, end );
						for ( uint32_t b = 0; b < n; ++b )
						{
							sets[s].blend_shapes( single, base[b], sh, fp16, weights[b], d, nv, begin, end );
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
					free( shapes );
					free( shapes16 );
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
	(void)state;
	plKernels sets[2];
	plBatchKernels batch[2];
	uint32_t set_count = plKernelSets( sets, batch );
	const uint32_t widths[4] = { 681 % 200 + 3, 130, 70, 19 };
	enum
	{
		N = 11
	};
	for ( uint32_t s = 0; s < set_count; ++s )
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
				plMlpBatchJob job = { net.layers, 3, activation, N, inputs, outputs, scratches, &batch[s], NULL };
				assert_int_equal( plMlpBatchJob_Run( &job ), PLEAT_RESULT_OK );
				for ( uint32_t b = 0; b < N; ++b )
				{
					plMlpJob one = { net.layers,
									 3,
									 activation,
									 inputs[b],
									 plMakeSpan( single, widths[3], 4 ),
									 plMakeSpan( single_scratch, 2 * 130, 4 ),
									 &sets[s],
									 NULL };
					assert_int_equal( plMlpJob_Run( &one ), PLEAT_RESULT_OK );
					assert_memory_equal( single, ys[b], widths[3] * sizeof( float ) );
				}

				// Invalid jobs are rejected before anything is written.
				plMlpBatchJob bad = job;
				bad.batch_count = 0;
				assert_int_equal( plMlpBatchJob_Run( &bad ), PLEAT_RESULT_INVALID_ARGUMENT );
				bad = job;
				bad.batch_count = PLEAT_BATCH_MAX + 1;
				assert_false( plMlpBatchJob_Validate( &bad ) );
				bad = job;
				bad.activation = 7;
				assert_false( plMlpBatchJob_Validate( &bad ) );
				bad = job;
				bad.kernels = NULL;
				assert_false( plMlpBatchJob_Validate( &bad ) );
				plSpan short_scratch[N];
				memcpy( short_scratch, scratches, sizeof( scratches ) );
				short_scratch[N - 1] = plMakeSpan( scratch[N - 1], 2 * 130 - 1, 4 );
				bad = job;
				bad.scratch = short_scratch;
				assert_false( plMlpBatchJob_Validate( &bad ) );
				plConstSpan short_inputs[N];
				memcpy( short_inputs, inputs, sizeof( inputs ) );
				short_inputs[3] = plMakeConstSpan( xs[3], widths[0] - 1, 4 );
				bad = job;
				bad.inputs = short_inputs;
				assert_false( plMlpBatchJob_Validate( &bad ) );
				free( net.storage );
			}
		}
	}
}

static void test_blend_batch_job_rejects_bad_spans( void** state )
{
	(void)state;
	plKernels k;
	plSelectKernels( &k, 1 );
	plBatchKernels bk;
	assert_true( plSelectBatchKernels( &k, &bk ) );
	static float shapes[4 * 10 * 3], base[2][30], out[2][30], w[2][4];
	plConstSpan bases[2] = { plMakeConstSpan( base[0], 10, 12 ), plMakeConstSpan( base[1], 10, 12 ) };
	plConstSpan weights[2] = { plMakeConstSpan( w[0], 4, 4 ), plMakeConstSpan( w[1], 4, 4 ) };
	plSpan outs[2] = { plMakeSpan( out[0], 10, 12 ), plMakeSpan( out[1], 10, 12 ) };
	plBlendShapesBatchJob job = { 2, bases, weights, outs, shapes, 0, 10, 0, 10, &bk };
	assert_int_equal( plBlendShapesBatchJob_Run( &job ), PLEAT_RESULT_OK );
	plBlendShapesBatchJob bad = job;
	bad.vertex_end = 11;
	assert_int_equal( plBlendShapesBatchJob_Run( &bad ), PLEAT_RESULT_INVALID_ARGUMENT );
	bad = job;
	bad.vertex_begin = 5;
	bad.vertex_end = 4;
	assert_false( plBlendShapesBatchJob_Validate( &bad ) );
	plConstSpan mixed[2] = { plMakeConstSpan( w[0], 4, 4 ), plMakeConstSpan( w[1], 3, 4 ) };
	bad = job;
	bad.weights = mixed;
	assert_false( plBlendShapesBatchJob_Validate( &bad ) );
	plSpan aliased[2] = { plMakeSpan( base[0], 10, 12 ), plMakeSpan( out[1], 10, 12 ) };
	bad = job;
	bad.outputs = aliased;
	assert_false( plBlendShapesBatchJob_Validate( &bad ) );
	bad = job;
	bad.batch_count = 0;
	assert_false( plBlendShapesBatchJob_Validate( &bad ) );
	bad = job;
	bad.blend_shapes = NULL;
	assert_false( plBlendShapesBatchJob_Validate( &bad ) );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_mat_mat_equals_mat_vec_per_instance ),
		cmocka_unit_test( test_mat_mat_avx2_within_rounding_of_scalar_spec ),
		cmocka_unit_test( test_blend_batch_equals_blend_per_instance ),
		cmocka_unit_test( test_mlp_batch_job_equals_mlp_job_per_instance ),
		cmocka_unit_test( test_blend_batch_job_rejects_bad_spans ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
