// Step and MLP timings for docs/benchmarks.md (run through scripts/bench.sh; not a test).
//
// usage: pleat_bench_step --asset FP32.pleat --case case.bin [--asset-fp16 FP16.pleat] [--iterations N]
//                         [--warmup N] [--scalar-iterations N] [--onnxruntime LIB] [--clock wall|cpu]
//                         [--out step.json] [--step-only [--workers 1|2]]
//
// FP32.pleat needs the OXLP/OXDC sections (pleat-pack --onnx) for the ONNX Runtime numbers; case.bin is the golden
// motion of `python -m pleat.reference.golden` (only its poses are used). Every number is a median over N timed
// iterations after a warm-up, on the calling thread only:
//   pleat_mlp_us   latent predictor + decoder with Pleat's CPU kernels (the context's dispatch: AVX2 or scalar)
//   ort_mlp_us     the same two networks, same fp32 weights, through ONNX Runtime (1 intra-op thread), measured
//                  alternately with pleat_mlp_us in one loop (even iterations Pleat first, odd ones ORT first)
//   pleat_mlp_fp16_us, pleat_blend_us, pleat_blend_fp16_us  the MLPs on fp16 weights and the blend-shape
//                  accumulation alone (fp32 / fp16 BLND), to split a step into its memory-bound parts
//   pleat_step_us  plInstance_Step on the fp32 asset, the asset's motion looped (reset at each wrap)
//   pleat_step_fp16_us, scalar_step_us (a context with force_scalar), ort_step_us (instance with the ORT backend),
//   pleat_step_2workers_us, pleat_step_fp16_2workers_us (the context given a two-worker task system: this thread +
//   one helper thread)
//   fp16_max_position_diff_mm, fp16_rms_position_diff_mm, fp16_max_normal_diff_deg: the accuracy cost of the fp16
//   asset, both assets stepped through the same motion (not timed)
//   stream_floor_us, stream_floor_fp16_us: the memory floor, a pure streaming read (no arithmetic but an integer XOR;
//                  AVX2 loads over eight concurrent streams where available)
//                  of exactly the bytes a step must stream: every MLP weight and bias, then the blend shapes, timed
//                  per pass like a step (so the same cache residency from one pass to the next), from huge pages like
//                  the step's asset block (stream_floor_small_pages_us: from plain 4 KiB pages); step_stream_mb
//   pleat_step_small_pages_us: pleat_step_us with host allocator hooks that give the asset plain 4 KiB pages (every
//                  other step timing loads the asset through the SDK's default allocator: huge pages on Linux)
// --step-only times nothing but plInstance_Step on --asset (fp32 or fp16), optionally with --workers 2; --small-pages
// (with --step-only or --phases) gives the context the plain allocator hooks.
// pleat_bench_phases (the same file against the library built with PLEAT_STEP_PHASES, bench/CMakeLists.txt) adds
// --phases: the per-phase medians of one-thread steps on --asset and --asset-fp16 (sdk/src/core/step_phases.h), as JSON.
#define _POSIX_C_SOURCE 200809L
#define _DEFAULT_SOURCE // madvise: the memory floor is read from huge pages, as the step's asset block (context.c)
#include "pleat/pleat.h"

#include "asset.h"
#include "bench_support.h"
#include "jobs.h"
#include "kernels.h"
#include "ort_backend.h"
#include "step_phases.h"

#if defined( __x86_64__ ) && ( defined( __GNUC__ ) || defined( __clang__ ) )
#include <immintrin.h>
#define BENCH_HAVE_AVX2_STREAM 1
#endif
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

// ---- small helpers ----

static int Fail( const char* what, plResult result )
{
	fprintf( stderr, "pleat_bench_step: %s: %s\n", what, plResultString( result ) );
	return 1;
}

// ---- Pleat's MLP: the instance's own job (mlp.c), serial, with the context's kernel choice ----

static plResult PleatMlp( const plKernels* kernels, const plLayer* layers, uint32_t layer_count, uint32_t activation,
						  const float* input, float* scratch, uint32_t scratch_count, float* output )
{
	plMlpJob job;
	memset( &job, 0, sizeof( job ) );
	job.layers = layers;
	job.layer_count = layer_count;
	job.activation = activation;
	job.input = plMakeConstSpan( input, layers[0].in_count, 4 );
	job.output = plMakeSpan( output, layers[layer_count - 1].out_count, 4 );
	job.scratch = plMakeSpan( scratch, scratch_count, 4 );
	job.kernels = kernels;
	job.runner = NULL;
	return plMlpJob_Run( &job );
}

static void* BenchAlloc( size_t size, size_t align, void* user )
{
	(void)user;
	return aligned_alloc( align, ( size + align - 1 ) / align * align );
}

static void BenchFree( void* ptr, size_t size, void* user )
{
	(void)size;
	(void)user;
	free( ptr );
}

typedef struct MlpTimes
{
	double pleat_us;
	double ort_us;
	double max_abs_diff; // |w_Pleat − w_ORT| after the last iteration (each chains its own LP → decoder)
	int have_ort;
	plResult ort_result;
	plResult pleat_result;
} MlpTimes;

static void TimeMlps( const plAssetData* asset, const char* ort_library, uint32_t warmup, uint32_t iterations,
					  MlpTimes* times )
{
	plKernels kernels;
	plChooseKernels( &kernels, PLEAT_KERNEL_SET_AVX512 );
	uint32_t width = asset->input_count;
	for ( uint32_t i = 0; i < asset->lp_layer_count; ++i )
		width = asset->lp[i].out_count > width ? asset->lp[i].out_count : width;
	for ( uint32_t i = 0; i < asset->dec_layer_count; ++i )
		width = asset->dec[i].out_count > width ? asset->dec[i].out_count : width;
	float* x = (float*)aligned_alloc( 64, 4 * (size_t)( width + 16 ) );
	uint32_t scratch_count = 2 * width;
	float* scratch = (float*)aligned_alloc( 64, 4 * (size_t)scratch_count );
	float* latent_pleat = (float*)aligned_alloc( 64, 4 * (size_t)( width + 16 ) );
	float* latent_ort = (float*)aligned_alloc( 64, 4 * (size_t)( width + 16 ) );
	float* weights_pleat = (float*)aligned_alloc( 64, 4 * (size_t)( width + 16 ) );
	float* weights_ort = (float*)aligned_alloc( 64, 4 * (size_t)( width + 16 ) );
	uint32_t seed = 7u;
	for ( uint32_t i = 0; i < asset->input_count; ++i ) // a normalised input: roughly unit scale
	{
		seed = seed * 1664525u + 1013904223u;
		x[i] = (float)( (int32_t)( seed >> 8 ) - ( 1 << 23 ) ) / (float)( 1 << 23 );
	}

	plAllocator allocator = { BenchAlloc, BenchFree, NULL };
	plOrtMlp* ort_lp = NULL;
	plOrtMlp* ort_dec = NULL;
	times->have_ort = 0;
	times->ort_result = PLEAT_RESULT_BACKEND_UNAVAILABLE;
	times->pleat_result = PLEAT_RESULT_OK;
	if ( asset->onnx_lp != NULL && asset->onnx_dec != NULL )
	{
		times->ort_result = plOrtMlp_Create( ort_library, asset->onnx_lp, asset->onnx_lp_size, asset->input_count,
											 asset->latent_count, &allocator, &ort_lp );
		if ( times->ort_result == PLEAT_RESULT_OK )
		{
			times->ort_result = plOrtMlp_Create( ort_library, asset->onnx_dec, asset->onnx_dec_size,
												 asset->latent_count, asset->blend_count, &allocator, &ort_dec );
		}
		times->have_ort = times->ort_result == PLEAT_RESULT_OK;
	}

	double* pleat_us = (double*)malloc( sizeof( double ) * iterations );
	double* ort_us = (double*)malloc( sizeof( double ) * iterations );
	for ( uint32_t it = 0; it < warmup + iterations; ++it )
	{
		double t_pleat = 0.0;
		double t_ort = 0.0;
		for ( int turn = 0; turn < 2; ++turn )
		{
			int pleat_turn = ( turn == 0 ) == ( it % 2 == 0 );
			if ( pleat_turn )
			{
				double t0 = BenchNowUs();
				plResult r = PleatMlp( &kernels, asset->lp, asset->lp_layer_count, asset->lp_activation, x, scratch,
									   scratch_count, latent_pleat );
				if ( r == PLEAT_RESULT_OK )
					r = PleatMlp( &kernels, asset->dec, asset->dec_layer_count, asset->dec_activation, latent_pleat,
								  scratch, scratch_count, weights_pleat );
				if ( r != PLEAT_RESULT_OK )
					times->pleat_result = r;
				t_pleat = BenchNowUs() - t0;
			}
			else if ( times->have_ort )
			{
				double t0 = BenchNowUs();
				plOrtMlp_Run( ort_lp, x, latent_ort );
				plOrtMlp_Run( ort_dec, latent_ort, weights_ort );
				t_ort = BenchNowUs() - t0;
			}
		}
		if ( it >= warmup )
		{
			pleat_us[it - warmup] = t_pleat;
			ort_us[it - warmup] = t_ort;
		}
	}
	times->max_abs_diff = 0.0;
	if ( times->have_ort )
	{
		for ( uint32_t i = 0; i < asset->blend_count; ++i )
		{
			double d = fabs( (double)weights_pleat[i] - (double)weights_ort[i] );
			times->max_abs_diff = d > times->max_abs_diff ? d : times->max_abs_diff;
		}
	}
	times->pleat_us = BenchMedian( pleat_us, iterations );
	times->ort_us = times->have_ort ? BenchMedian( ort_us, iterations ) : NAN;
	plOrtMlp_Destroy( ort_lp );
	plOrtMlp_Destroy( ort_dec );
	free( pleat_us );
	free( ort_us );
	free( x );
	free( scratch );
	free( latent_pleat );
	free( latent_ort );
	free( weights_pleat );
	free( weights_ort );
}

// Pleat's MLPs alone (e.g. on the fp16 asset, which has no ONNX twin).
static double TimePleatMlpOnly( const plAssetData* asset, uint32_t warmup, uint32_t iterations )
{
	for ( uint32_t i = 0; i < asset->lp_layer_count; ++i )
		if ( asset->lp[i].out_count > 1024 )
			return NAN;
	for ( uint32_t i = 0; i < asset->dec_layer_count; ++i )
		if ( asset->dec[i].out_count > 1024 )
			return NAN;
	plKernels kernels;
	plChooseKernels( &kernels, PLEAT_KERNEL_SET_AVX512 );
	float* buffers = (float*)aligned_alloc( 64, 4 * 4096 );
	float* x = buffers;
	float* latent = buffers + 1024;
	float* scratch = buffers + 2048; // 2048 floats: up to 1024-wide hidden layers
	float* weights = buffers + 1536;
	for ( uint32_t i = 0; i < asset->input_count && i < 1024; ++i )
	{
		x[i] = (float)( ( i * 37u ) % 100u ) / 50.0f - 1.0f;
	}
	double* us = (double*)malloc( sizeof( double ) * iterations );
	for ( uint32_t it = 0; it < warmup + iterations; ++it )
	{
		double t0 = BenchNowUs();
		PleatMlp( &kernels, asset->lp, asset->lp_layer_count, asset->lp_activation, x, scratch, 2048, latent );
		PleatMlp( &kernels, asset->dec, asset->dec_layer_count, asset->dec_activation, latent, scratch, 2048, weights );
		if ( it >= warmup )
			us[it - warmup] = BenchNowUs() - t0;
	}
	double median = BenchMedian( us, iterations );
	free( us );
	free( buffers );
	return median;
}

// The blend-shape accumulation alone over all vertices (the other memory-bound stage of a step).
static double TimeBlendOnly( const plAssetData* asset, uint32_t warmup, uint32_t iterations )
{
	plKernels kernels;
	plChooseKernels( &kernels, PLEAT_KERNEL_SET_AVX512 );
	size_t floats = (size_t)asset->vertex_count * 3;
	float* out = (float*)aligned_alloc( 64, ( 4 * floats + 63 ) / 64 * 64 );
	float* weights = (float*)aligned_alloc( 64, ( 4 * (size_t)asset->blend_count + 63 ) / 64 * 64 );
	for ( uint32_t j = 0; j < asset->blend_count; ++j )
	{
		weights[j] = 0.05f * (float)( (int)( j % 7 ) - 3 );
	}
	double* us = (double*)malloc( sizeof( double ) * iterations );
	for ( uint32_t it = 0; it < warmup + iterations; ++it )
	{
		double t0 = BenchNowUs();
		kernels.blend_shapes( out, asset->template_positions, &asset->blend_shapes, weights, asset->blend_count,
							  asset->vertex_count, 0, asset->vertex_count );
		if ( it >= warmup )
			us[it - warmup] = BenchNowUs() - t0;
	}
	double median = BenchMedian( us, iterations );
	free( us );
	free( out );
	free( weights );
	return median;
}

// ---- the memory floor: a pure streaming read of the bytes a step must read ----

static uint64_t XorStream( const void* p, size_t bytes, uint64_t acc )
{
	const uint64_t* w = (const uint64_t*)p;
	size_t n = bytes / 8;
	uint64_t a0 = 0, a1 = 0, a2 = 0, a3 = 0;
	size_t i = 0;
	for ( ; i + 4 <= n; i += 4 )
	{
		a0 ^= w[i];
		a1 ^= w[i + 1];
		a2 ^= w[i + 2];
		a3 ^= w[i + 3];
	}
	for ( ; i < n; ++i )
		a0 ^= w[i];
	return acc ^ a0 ^ a1 ^ a2 ^ a3;
}

#if defined( BENCH_HAVE_AVX2_STREAM )
// The fastest read found on this machine (docs/benchmarks.md): 32-byte loads over eight concurrent sequential streams
// (the eighths of the range), like the blend kernel's several streams; a single 8-byte stream reads ~35 % slower.
__attribute__( ( target( "avx2" ) ) ) static uint64_t XorStreamAvx2( const void* p, size_t bytes, uint64_t acc )
{
	const uint8_t* b = (const uint8_t*)p;
	size_t eighth = ( bytes / 8 ) & ~(size_t)31;
	__m256i a[8];
	for ( int s = 0; s < 8; ++s )
		a[s] = _mm256_setzero_si256();
	for ( size_t i = 0; i < eighth; i += 32 )
		for ( int s = 0; s < 8; ++s )
			a[s] = _mm256_xor_si256( a[s], _mm256_loadu_si256( (const __m256i*)( b + (size_t)s * eighth + i ) ) );
	__m256i r = a[0];
	for ( int s = 1; s < 8; ++s )
		r = _mm256_xor_si256( r, a[s] );
	uint64_t lanes[4];
	_mm256_storeu_si256( (__m256i*)lanes, r );
	return XorStream( b + 8 * eighth, bytes - 8 * eighth, acc ^ lanes[0] ^ lanes[1] ^ lanes[2] ^ lanes[3] );
}
#endif

static uint64_t ReadStream( const void* p, size_t bytes, uint64_t acc )
{
#if defined( BENCH_HAVE_AVX2_STREAM )
	if ( __builtin_cpu_supports( "avx2" ) )
		return XorStreamAvx2( p, bytes, acc );
#endif
	return XorStream( p, bytes, acc );
}

static uint64_t StreamStepBytes( const plAssetData* a, size_t* out_bytes )
{
	uint64_t acc = 0;
	size_t total = 0;
	for ( int net = 0; net < 2; ++net )
	{
		const plLayer* layers = net == 0 ? a->lp : a->dec;
		uint32_t count = net == 0 ? a->lp_layer_count : a->dec_layer_count;
		for ( uint32_t i = 0; i < count; ++i )
		{
			size_t wb = (size_t)layers[i].out_count * layers[i].in_count * ( layers[i].weight_fp16 ? 2u : 4u );
			acc = ReadStream( layers[i].weight, wb, acc );
			acc = ReadStream( layers[i].bias, (size_t)layers[i].out_count * 4u, acc );
			total += wb + (size_t)layers[i].out_count * 4u;
		}
	}
	size_t bb = (size_t)a->blend_count * a->vertex_count * 3u * plShapeBytes( a->blend_shapes.type );
	acc = ReadStream( a->blend_shapes.data, bb, acc );
	*out_bytes = total + bb;
	return acc;
}

static volatile uint64_t g_stream_sink;

// The floor over a copy of the asset in memory like the SDK default allocator's (2 MiB aligned, advised for huge
// pages), or, with small_pages, in the caller's plain buffer.
static double TimeStreamFloor( const uint8_t* asset_bytes, size_t asset_size, int small_pages, uint32_t warmup,
							   uint32_t iterations, double* out_mb )
{
	size_t huge = (size_t)2 << 20, rounded = ( asset_size + huge - 1 ) / huge * huge;
	uint8_t* copy = small_pages ? NULL : (uint8_t*)aligned_alloc( huge, rounded );
	if ( copy != NULL )
	{
		madvise( copy, rounded, MADV_HUGEPAGE );
		memcpy( copy, asset_bytes, asset_size );
	}
	plAssetData asset;
	if ( plAssetData_Parse( copy != NULL ? copy : asset_bytes, asset_size, 0, &asset ) != PLEAT_RESULT_OK )
	{
		free( copy );
		return NAN;
	}
	double* us = (double*)malloc( sizeof( double ) * iterations );
	size_t bytes = 0;
	for ( uint32_t it = 0; it < warmup + iterations; ++it )
	{
		double t0 = BenchNowUs();
		g_stream_sink ^= StreamStepBytes( &asset, &bytes );
		if ( it >= warmup )
			us[it - warmup] = BenchNowUs() - t0;
	}
	double median = BenchMedian( us, iterations );
	free( us );
	free( copy );
	*out_mb = (double)bytes / 1e6;
	return median;
}

// ---- full step through the public API ----

#if defined( PLEAT_STEP_PHASES )
static double* g_phase_samples; // [PLEAT_PHASE_COUNT][iterations] per-phase µs of each timed step, when set
static const char* const k_phase_names[PLEAT_PHASE_COUNT] = { "validate", "fk", "input_assembly", "lp_mlp",
															   "latent_guard_dec_mlp", "blend_shapes", "skinning",
															   "body_contact", "face_normals", "vertex_normals",
															   "guards", "commit_copy" };
#endif

typedef struct StepConfig
{
	const uint8_t* asset_bytes;
	size_t asset_size;
	int force_scalar;
	plMlpBackend backend;
	const char* ort_library;
	BenchTwoWorkers* workers; // NULL = serial
	int small_pages;     // host allocator hooks without huge pages (see BenchAlloc)
	float network_rate_hz; // plInstanceDef.network_rate_hz (0 = the networks every step)
	float dt_s;            // > 0: every step's dt instead of the motion's (a game loop's fixed rate)
	double* out_mean_us;   // optional: the mean step time (steps differ in cost when a network rate is set)
} StepConfig;

// --small-pages: the context gets host allocator hooks that are plain aligned_alloc/free (BenchAlloc), i.e. an engine allocator
// that does not give large blocks huge pages. Without it the SDK's default allocator is used, which puts blocks of
// 2 MiB and more (the asset) in transparent huge pages on Linux (context.c).
static int g_small_pages;

static plResult TimeSteps( const StepConfig* config, const BenchMotion* motion, uint32_t warmup, uint32_t iterations,
						   double* out_median_us, int* out_avx2 )
{
	plContextDef cdef = plDefaultContextDef();
	cdef.force_scalar = config->force_scalar;
	if ( config->small_pages )
	{
		cdef.alloc = BenchAlloc;
		cdef.free = BenchFree;
	}
	if ( config->workers != NULL )
	{
		BenchTwoWorkers_Install( config->workers, &cdef );
	}
	plContext context;
	plResult result = plCreateContext( &cdef, &context );
	if ( result != PLEAT_RESULT_OK )
	{
		return result;
	}
	plKernelSet kernel_set = PLEAT_KERNEL_SET_SCALAR;
	if ( out_avx2 != NULL && plContext_GetKernelSet( context, &kernel_set ) == PLEAT_RESULT_OK )
	{
		*out_avx2 = kernel_set != PLEAT_KERNEL_SET_SCALAR; // the single-instance kernels are AVX2's in both SIMD sets
	}
	plAssetDef adef = plDefaultAssetDef();
	adef.data = config->asset_bytes;
	adef.size = config->asset_size;
	adef.flags = 0; // copied into the context's memory, as an engine that hands over a buffer it then frees
	plAsset asset;
	result = plLoadAsset( context, &adef, &asset );
	plInstance instance = { 0 };
	if ( result == PLEAT_RESULT_OK )
	{
		plInstanceDef idef = plDefaultInstanceDef();
		idef.asset = asset;
		idef.beta = motion->beta;
		idef.beta_count = motion->beta_count;
		idef.material = motion->material;
		idef.mlp_backend = config->backend;
		idef.onnxruntime_library = config->ort_library;
		idef.network_rate_hz = config->network_rate_hz;
		result = plCreateInstance( context, &idef, &instance );
	}
	double* step_us = (double*)malloc( sizeof( double ) * iterations );
#if defined( PLEAT_STEP_PHASES )
	g_plStepPhaseClock = (int)g_benchClock;
#endif
	for ( uint32_t it = 0; result >= 0 && it < warmup + iterations; ++it )
	{
		uint32_t f = it % motion->frame_count;
		if ( f == 0 )
		{
			plInstance_Reset( instance );
		}
		plFrameInput in = BenchMotionFrame( motion, f );
		if ( config->dt_s > 0.0f )
		{
			in.dt_s = config->dt_s;
		}
#if defined( PLEAT_STEP_PHASES )
		plStepPhaseReset();
#endif
		double t0 = BenchNowUs();
		plResult step = plInstance_Step( instance, &in, NULL );
		double t1 = BenchNowUs();
		if ( step < 0 )
		{
			result = step;
		}
		else if ( it >= warmup )
		{
			step_us[it - warmup] = t1 - t0;
#if defined( PLEAT_STEP_PHASES )
			if ( g_phase_samples != NULL )
				for ( int p = 0; p < PLEAT_PHASE_COUNT; ++p )
					g_phase_samples[(size_t)p * iterations + ( it - warmup )] = g_plStepPhaseUs[p];
#endif
		}
	}
	if ( result >= 0 )
	{
		if ( config->out_mean_us != NULL )
		{
			double sum = 0.0;
			for ( uint32_t i = 0; i < iterations; ++i )
				sum += step_us[i];
			*config->out_mean_us = sum / iterations;
		}
		*out_median_us = BenchMedian( step_us, iterations );
		result = PLEAT_RESULT_OK;
	}
	free( step_us );
	plDestroyContext( context );
	return result;
}

// ---- accuracy cost of the fp16 asset: the same motion through both assets, positions and normals compared ----

typedef struct Fp16Cost
{
	double max_position_diff_m;  // max over frames and vertices of |x_fp16 − x_fp32|
	double rms_position_diff_m;  // over frames and vertices
	double max_normal_angle_deg; // max angle between the two normals
} Fp16Cost;

static plResult CreateStepper( const uint8_t* bytes, size_t size, const BenchMotion* motion, plContext* context,
							   plInstance* instance )
{
	plContextDef cdef = plDefaultContextDef();
	plResult result = plCreateContext( &cdef, context );
	if ( result != PLEAT_RESULT_OK )
		return result;
	plAssetDef adef = plDefaultAssetDef();
	adef.data = bytes;
	adef.size = size;
	adef.flags = PLEAT_ASSET_FLAG_USE_IN_PLACE;
	plAsset asset;
	result = plLoadAsset( *context, &adef, &asset );
	if ( result != PLEAT_RESULT_OK )
		return result;
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = asset;
	idef.beta = motion->beta;
	idef.beta_count = motion->beta_count;
	idef.material = motion->material;
	result = plCreateInstance( *context, &idef, instance );
	return result < 0 ? result : PLEAT_RESULT_OK;
}

static plResult MeasureFp16Cost( const uint8_t* fp32_bytes, size_t fp32_size, const uint8_t* fp16_bytes,
								 size_t fp16_size, const BenchMotion* motion, Fp16Cost* cost )
{
	plContext c32 = { 0, 0 }, c16 = { 0, 0 };
	plInstance i32, i16;
	plResult result = CreateStepper( fp32_bytes, fp32_size, motion, &c32, &i32 );
	if ( result == PLEAT_RESULT_OK )
		result = CreateStepper( fp16_bytes, fp16_size, motion, &c16, &i16 );
	memset( cost, 0, sizeof( *cost ) );
	double sum_sq = 0.0;
	size_t count = 0;
	for ( uint32_t f = 0; result == PLEAT_RESULT_OK && f < motion->frame_count; ++f )
	{
		plFrameInput in = BenchMotionFrame( motion, f );
		plResult a = plInstance_Step( i32, &in, NULL );
		plResult b = plInstance_Step( i16, &in, NULL );
		if ( a < 0 || b < 0 )
		{
			result = a < 0 ? a : b;
			break;
		}
		const float *p32, *p16, *n32, *n16;
		uint32_t n = 0;
		plInstance_GetPositions( i32, &p32, &n );
		plInstance_GetPositions( i16, &p16, NULL );
		plInstance_GetNormals( i32, &n32, NULL );
		plInstance_GetNormals( i16, &n16, NULL );
		for ( uint32_t v = 0; v < n; ++v )
		{
			double dx = (double)p16[v * 3] - p32[v * 3], dy = (double)p16[v * 3 + 1] - p32[v * 3 + 1],
				   dz = (double)p16[v * 3 + 2] - p32[v * 3 + 2];
			double d2 = dx * dx + dy * dy + dz * dz;
			sum_sq += d2;
			count += 1;
			cost->max_position_diff_m = fmax( cost->max_position_diff_m, sqrt( d2 ) );
			double dot = (double)n16[v * 3] * n32[v * 3] + (double)n16[v * 3 + 1] * n32[v * 3 + 1] +
						 (double)n16[v * 3 + 2] * n32[v * 3 + 2];
			dot = dot > 1.0 ? 1.0 : ( dot < -1.0 ? -1.0 : dot );
			cost->max_normal_angle_deg = fmax( cost->max_normal_angle_deg, acos( dot ) * 57.29577951308232 );
		}
	}
	cost->rms_position_diff_m = count > 0 ? sqrt( sum_sq / (double)count ) : NAN;
	if ( c32.index1 != 0 )
		plDestroyContext( c32 );
	if ( c16.index1 != 0 )
		plDestroyContext( c16 );
	return result;
}

// ---- main ----

static void PrintJsonNumber( FILE* out, const char* key, double value, int last )
{
	if ( isfinite( value ) )
		fprintf( out, "  \"%s\": %.2f%s\n", key, value, last ? "" : "," );
	else
		fprintf( out, "  \"%s\": null%s\n", key, last ? "" : "," );
}

static void PrintJsonPrecise( FILE* out, const char* key, double value )
{
	if ( isfinite( value ) )
		fprintf( out, "  \"%s\": %.4g,\n", key, value );
	else
		fprintf( out, "  \"%s\": null,\n", key );
}

int main( int argc, char** argv )
{
	const char* asset_path = NULL;
	const char* fp16_path = NULL;
	const char* case_path = NULL;
	const char* ort_library = NULL;
	const char* out_path = NULL;
	uint32_t iterations = 2000, warmup = 200, scalar_iterations = 300;
	int step_only = 0, phases = 0;
	uint32_t step_only_workers = 1;
	for ( int i = 1; i < argc; i += 2 )
	{
		if ( strcmp( argv[i], "--small-pages" ) == 0 )
		{
			g_small_pages = 1;
			i -= 1;
			continue;
		}
		if ( strcmp( argv[i], "--step-only" ) == 0 || strcmp( argv[i], "--phases" ) == 0 )
		{
			step_only = step_only || argv[i][2] == 's';
			phases = phases || argv[i][2] == 'p';
			i -= 1;
			continue;
		}
		if ( i + 1 >= argc )
		{
			fprintf( stderr, "pleat_bench_step: %s needs a value\n", argv[i] );
			return 2;
		}
		if ( strcmp( argv[i], "--asset" ) == 0 )
			asset_path = argv[i + 1];
		else if ( strcmp( argv[i], "--asset-fp16" ) == 0 )
			fp16_path = argv[i + 1];
		else if ( strcmp( argv[i], "--case" ) == 0 )
			case_path = argv[i + 1];
		else if ( strcmp( argv[i], "--onnxruntime" ) == 0 )
			ort_library = argv[i + 1];
		else if ( strcmp( argv[i], "--clock" ) == 0 )
			g_benchClock = strcmp( argv[i + 1], "cpu" ) == 0 ? CLOCK_THREAD_CPUTIME_ID : CLOCK_MONOTONIC;
		else if ( strcmp( argv[i], "--out" ) == 0 )
			out_path = argv[i + 1];
		else if ( strcmp( argv[i], "--iterations" ) == 0 )
			iterations = (uint32_t)strtoul( argv[i + 1], NULL, 10 );
		else if ( strcmp( argv[i], "--warmup" ) == 0 )
			warmup = (uint32_t)strtoul( argv[i + 1], NULL, 10 );
		else if ( strcmp( argv[i], "--workers" ) == 0 )
			step_only_workers = (uint32_t)strtoul( argv[i + 1], NULL, 10 );
		else if ( strcmp( argv[i], "--scalar-iterations" ) == 0 )
			scalar_iterations = (uint32_t)strtoul( argv[i + 1], NULL, 10 );
		else
		{
			fprintf( stderr, "pleat_bench_step: unknown option %s\n", argv[i] );
			return 2;
		}
	}
	if ( asset_path == NULL || case_path == NULL || iterations == 0 )
	{
		fprintf( stderr, "usage: pleat_bench_step --asset FP32.pleat --case case.bin [--asset-fp16 FP16.pleat] "
						 "[--iterations N] [--warmup N] [--scalar-iterations N] [--onnxruntime LIB] [--clock wall|cpu] "
						 "[--out JSON]\n" );
		return 2;
	}

	size_t asset_size = 0;
	uint8_t* asset_bytes = BenchReadFile( asset_path, &asset_size );
	if ( asset_bytes == NULL )
	{
		fprintf( stderr, "pleat_bench_step: cannot read %s\n", asset_path );
		return 1;
	}
	plAssetData asset;
	plResult result = plAssetData_Parse( asset_bytes, asset_size, 0, &asset );
	if ( result != PLEAT_RESULT_OK )
	{
		return Fail( asset_path, result );
	}
	BenchMotion motion;
	memset( &motion, 0, sizeof( motion ) );
	if ( !BenchReadMotion( case_path, &motion ) || motion.joint_count != asset.joint_count )
	{
		fprintf( stderr, "pleat_bench_step: %s is not a golden case for this asset\n", case_path );
		return 1;
	}

#if defined( PLEAT_STEP_PHASES )
	if ( phases )
	{
		FILE* out = BenchOpenOutput( "pleat_bench_phases", out_path );
		if ( out == NULL )
			return 1;
		fprintf( out, "{\n" );
		for ( int which = 0; which < 2; ++which )
		{
			const char* path = which == 0 ? asset_path : fp16_path;
			size_t size = 0;
			uint8_t* bytes = which == 0 ? asset_bytes : ( path != NULL ? BenchReadFile( path, &size ) : NULL );
			if ( bytes == NULL )
				continue;
			StepConfig config = { bytes, which == 0 ? asset_size : size, 0, PLEAT_MLP_BACKEND_PLEAT, NULL, NULL,
								  g_small_pages, 0.0f, 0.0f, NULL };
			g_phase_samples = (double*)malloc( sizeof( double ) * PLEAT_PHASE_COUNT * iterations );
			double total_us = NAN;
			result = TimeSteps( &config, &motion, warmup, iterations, &total_us, NULL );
			fprintf( out, "%s  \"%s\": { \"step_us\": %.1f", which == 0 ? "" : ",\n", which == 0 ? "fp32" : "fp16",
					 total_us );
			double sum = 0.0;
			for ( int p = 0; p < PLEAT_PHASE_COUNT; ++p )
			{
				double m = BenchMedian( g_phase_samples + (size_t)p * iterations, iterations );
				sum += m;
				fprintf( out, ", \"%s\": %.1f", k_phase_names[p], m );
			}
			fprintf( out, ", \"sum_of_medians\": %.1f }", sum );
			free( g_phase_samples );
			g_phase_samples = NULL;
			if ( which == 1 )
				free( bytes );
			if ( result != PLEAT_RESULT_OK )
				return Fail( path, result );
		}
		fprintf( out, "\n}\n" );
		BenchCloseOutput( out );
		return 0;
	}
#endif
	if ( step_only ) // for profilers: nothing but fp32 plInstance_Step
	{
		StepConfig only = { asset_bytes, asset_size, 0, PLEAT_MLP_BACKEND_PLEAT, NULL, NULL, g_small_pages, 0.0f, 0.0f,
							NULL };
		double only_us = NAN;
		BenchTwoWorkers helper;
		int with_helper = step_only_workers == 2 && BenchTwoWorkers_Start( &helper );
		only.workers = with_helper ? &helper : NULL;
		result = TimeSteps( &only, &motion, warmup, iterations, &only_us, NULL );
		if ( with_helper )
			BenchTwoWorkers_Stop( &helper );
		printf( "{ \"pleat_step_us\": %.2f }\n", only_us );
		return result == PLEAT_RESULT_OK ? 0 : 1;
	}

	MlpTimes mlp;
	TimeMlps( &asset, ort_library, warmup, iterations, &mlp );
	if ( mlp.pleat_result != PLEAT_RESULT_OK )
	{
		return Fail( "Pleat MLP", mlp.pleat_result );
	}
	fprintf( stderr, "mlp: pleat %.1f us, ort %.1f us (%s), max |w_pleat - w_ort| = %.3g\n", mlp.pleat_us, mlp.ort_us,
			 plResultString( mlp.ort_result ), mlp.max_abs_diff );

	double blend_us = TimeBlendOnly( &asset, warmup, iterations );
	double stream_mb = NAN, stream_fp16_mb = NAN, stream_fp16_us = NAN;
	double stream_us = TimeStreamFloor( asset_bytes, asset_size, 0, warmup, iterations, &stream_mb );
	double stream_small_us = TimeStreamFloor( asset_bytes, asset_size, 1, warmup, iterations, &stream_mb );
	double blend_fp16_us = NAN;
	StepConfig config = { asset_bytes, asset_size, 0, PLEAT_MLP_BACKEND_PLEAT, ort_library, NULL, 0, 0.0f, 0.0f, NULL };
	double step_us = NAN, step_fp16_us = NAN, scalar_us = NAN, ort_step_us = NAN, mlp_fp16_us = NAN;
	int avx2 = 0;
	result = TimeSteps( &config, &motion, warmup, iterations, &step_us, &avx2 );
	if ( result != PLEAT_RESULT_OK )
	{
		return Fail( "step (fp32)", result );
	}
	double step_small_pages_us = NAN;
	config.small_pages = 1;
	result = TimeSteps( &config, &motion, warmup, iterations, &step_small_pages_us, NULL );
	if ( result != PLEAT_RESULT_OK )
		fprintf( stderr, "small-pages step: %s\n", plResultString( result ) );
	config.small_pages = 0;
	// A 60 fps game loop: the networks on every step, against the networks at 30 Hz (plInstanceDef.network_rate_hz)
	// and the held deformation skinned in between. Means, not medians: with a rate the steps alternate in cost.
	double step_60fps_mean_us = NAN, step_60fps_net30_mean_us = NAN, unused_median_us;
	config.dt_s = 1.0f / 60.0f;
	config.out_mean_us = &step_60fps_mean_us;
	result = TimeSteps( &config, &motion, warmup, iterations, &unused_median_us, NULL );
	if ( result != PLEAT_RESULT_OK )
		fprintf( stderr, "60 fps step: %s\n", plResultString( result ) );
	config.network_rate_hz = 30.0f;
	config.out_mean_us = &step_60fps_net30_mean_us;
	result = TimeSteps( &config, &motion, warmup, iterations, &unused_median_us, NULL );
	if ( result != PLEAT_RESULT_OK )
		fprintf( stderr, "60 fps step, networks at 30 Hz: %s\n", plResultString( result ) );
	config.network_rate_hz = 0.0f;
	config.dt_s = 0.0f;
	config.out_mean_us = NULL;
	double step_2w_us = NAN, step_fp16_2w_us = NAN;
	BenchTwoWorkers pool;
	int have_pool = BenchTwoWorkers_Start( &pool );
	if ( have_pool )
	{
		config.workers = &pool;
		result = TimeSteps( &config, &motion, warmup, iterations, &step_2w_us, NULL );
		if ( result != PLEAT_RESULT_OK )
			fprintf( stderr, "2-worker step: %s\n", plResultString( result ) );
		config.workers = NULL;
	}
	config.force_scalar = 1;
	if ( scalar_iterations > 0 )
	{
		result = TimeSteps( &config, &motion, scalar_iterations / 10, scalar_iterations, &scalar_us, NULL );
		if ( result != PLEAT_RESULT_OK )
			fprintf( stderr, "scalar step: %s\n", plResultString( result ) );
	}
	config.force_scalar = 0;
	if ( mlp.have_ort )
	{
		config.backend = PLEAT_MLP_BACKEND_ONNXRUNTIME;
		result = TimeSteps( &config, &motion, warmup, iterations, &ort_step_us, NULL );
		if ( result != PLEAT_RESULT_OK )
			fprintf( stderr, "ort step: %s\n", plResultString( result ) );
		config.backend = PLEAT_MLP_BACKEND_PLEAT;
	}
	uint8_t* fp16_bytes = NULL;
	double fp16_max_mm = NAN, fp16_rms_mm = NAN, fp16_max_normal_deg = NAN;
	if ( fp16_path != NULL )
	{
		size_t fp16_size = 0;
		fp16_bytes = BenchReadFile( fp16_path, &fp16_size );
		if ( fp16_bytes != NULL )
		{
			config.asset_bytes = fp16_bytes;
			config.asset_size = fp16_size;
			result = TimeSteps( &config, &motion, warmup, iterations, &step_fp16_us, NULL );
			if ( result != PLEAT_RESULT_OK )
				fprintf( stderr, "fp16 step: %s\n", plResultString( result ) );
			if ( have_pool )
			{
				config.workers = &pool;
				result = TimeSteps( &config, &motion, warmup, iterations, &step_fp16_2w_us, NULL );
				if ( result != PLEAT_RESULT_OK )
					fprintf( stderr, "fp16 2-worker step: %s\n", plResultString( result ) );
				config.workers = NULL;
			}
			Fp16Cost cost;
			result = MeasureFp16Cost( asset_bytes, asset_size, fp16_bytes, fp16_size, &motion, &cost );
			if ( result == PLEAT_RESULT_OK )
			{
				fp16_max_mm = 1e3 * cost.max_position_diff_m;
				fp16_rms_mm = 1e3 * cost.rms_position_diff_m;
				fp16_max_normal_deg = cost.max_normal_angle_deg;
			}
			else
				fprintf( stderr, "fp16 accuracy: %s\n", plResultString( result ) );
			plAssetData fp16_asset;
			if ( plAssetData_Parse( fp16_bytes, fp16_size, 0, &fp16_asset ) == PLEAT_RESULT_OK &&
				 fp16_asset.input_count <= 1024 && fp16_asset.latent_count <= 512 && fp16_asset.blend_count <= 512 )
			{
				mlp_fp16_us = TimePleatMlpOnly( &fp16_asset, warmup, iterations );
				blend_fp16_us = TimeBlendOnly( &fp16_asset, warmup, iterations );
				stream_fp16_us = TimeStreamFloor( fp16_bytes, fp16_size, 0, warmup, iterations, &stream_fp16_mb );
			}
		}
	}

	if ( have_pool )
		BenchTwoWorkers_Stop( &pool );

	FILE* out = BenchOpenOutput( "pleat_bench_step", out_path );
	if ( out == NULL )
	{
		return 1;
	}
	fprintf( out, "{\n" );
	fprintf( out, "  \"vertices\": %u,\n", asset.vertex_count );
	fprintf( out, "  \"network\": \"I=%u LP %u layers, L=%u, decoder %u layers, D=%u, K=%u, Jin=%u\",\n",
			 asset.input_count, asset.lp_layer_count, asset.latent_count, asset.dec_layer_count, asset.blend_count,
			 asset.influence_count, asset.input_joint_count );
	fprintf( out, "  \"isa\": \"%s\",\n", avx2 ? "avx2+fma+f16c" : "scalar" );
	fprintf( out, "  \"clock\": \"%s\",\n", g_benchClock == CLOCK_MONOTONIC ? "wall" : "thread-cpu" );
	fprintf( out, "  \"iterations\": %u,\n", iterations );
	fprintf( out, "  \"warmup\": %u,\n", warmup );
	PrintJsonNumber( out, "pleat_mlp_us", mlp.pleat_us, 0 );
	PrintJsonNumber( out, "ort_mlp_us", mlp.ort_us, 0 );
	PrintJsonNumber( out, "mlp_speedup", mlp.have_ort ? mlp.ort_us / mlp.pleat_us : NAN, 0 );
	PrintJsonNumber( out, "pleat_mlp_fp16_us", mlp_fp16_us, 0 );
	if ( mlp.have_ort )
		fprintf( out, "  \"mlp_max_abs_diff\": %.3g,\n", mlp.max_abs_diff );
	PrintJsonNumber( out, "pleat_blend_us", blend_us, 0 );
	PrintJsonNumber( out, "pleat_blend_fp16_us", blend_fp16_us, 0 );
	PrintJsonNumber( out, "stream_floor_us", stream_us, 0 );
	PrintJsonNumber( out, "stream_floor_small_pages_us", stream_small_us, 0 );
	PrintJsonNumber( out, "stream_floor_fp16_us", stream_fp16_us, 0 );
	PrintJsonPrecise( out, "step_stream_mb", stream_mb );
	PrintJsonPrecise( out, "step_stream_fp16_mb", stream_fp16_mb );
	PrintJsonNumber( out, "pleat_step_us", step_us, 0 );
	PrintJsonNumber( out, "pleat_step_small_pages_us", step_small_pages_us, 0 );
	PrintJsonNumber( out, "pleat_step_fp16_us", step_fp16_us, 0 );
	PrintJsonNumber( out, "pleat_step_2workers_us", step_2w_us, 0 );
	PrintJsonNumber( out, "pleat_step_fp16_2workers_us", step_fp16_2w_us, 0 );
	PrintJsonNumber( out, "pleat_step_60fps_mean_us", step_60fps_mean_us, 0 );
	PrintJsonNumber( out, "pleat_step_60fps_net30hz_mean_us", step_60fps_net30_mean_us, 0 );
	PrintJsonNumber( out, "network_rate_30hz_speedup", step_60fps_mean_us / step_60fps_net30_mean_us, 0 );
	PrintJsonPrecise( out, "fp16_max_position_diff_mm", fp16_max_mm );
	PrintJsonPrecise( out, "fp16_rms_position_diff_mm", fp16_rms_mm );
	PrintJsonPrecise( out, "fp16_max_normal_diff_deg", fp16_max_normal_deg );
	PrintJsonNumber( out, "ort_step_us", ort_step_us, 0 );
	fprintf( out, "  \"scalar_iterations\": %u,\n", scalar_iterations );
	PrintJsonNumber( out, "scalar_step_us", scalar_us, 1 );
	fprintf( out, "}\n" );
	BenchCloseOutput( out );
	BenchFreeMotion( &motion );
	free( asset_bytes );
	free( fp16_bytes );
	return 0;
}
