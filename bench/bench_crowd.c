// Crowd timings for docs/scene-budget.md and the "crowd" keys of out/bench/step.json (run by scripts/bench.sh; not a
// test): per-instance µs of plStepInstances against stepping the same number of instances one by one with
// plInstance_Step, in the same run. Built as pleat_bench_crowd_phases (against the PLEAT_STEP_PHASES library copy)
// every entry also gets "batch_phase_us_per_instance": the batch's stages (sdk/src/core/step_phases.h), per instance.
//
// usage: pleat_bench_crowd --case case.bin --asset LABEL=PATH [--asset LABEL=PATH ...] [--counts 1,8,64,256]
//                          [--workers 1,2] [--seconds S] [--rounds R] [--clock wall|cpu] [--batch-isa best|avx2]
//                          [--body-contact on|fast|off] [--only batch|single] [--out crowd.json]
//        pleat_bench_crowd --scene --case case.bin --tier T0.pleat [--tier T1.pleat ...] --tier-errors e0,..,lbs
//                          --budgets B0,B1,.. [--characters 100] [--frames 120] [--clock cpu] [--workers 1|2]
//                          [--out scene.json]
//
// --scene (docs/scene-budget.md): a plScene of N characters at distances 2..40 m (importance 1 / distance²) on one
// thread (--workers 2: this thread and one helper, wall clock), 60 fps. First the calibration, in the same run: per character µs (mean frame) of every tier at its full rate and at 15 Hz
// (giving the cost between network updates) and of LBS-only, all characters on that detail, and of one lone character
// (the tier's stream cost: what a group pays once); then for each budget a scene with those costs and the given errors
// (mm, e.g. pleat.eval.suite's mean per tier and its LBS-only mean), 60 untimed frames and F timed ones, every frame's
// measured cost reported back with --report-costs (plScene_ReportFrameCost, as an engine could): the median
// and p90 frame time against the budget, the plan's cost, its importance-weighted and plain mean error, and how many
// characters ended on each detail. Budget 0 = unlimited.
//
// For every asset, worker count and instance count n: a context (two workers = this thread + one helper thread,
// bench_support.c), two sets of n instances of the asset with different β, each instance on its own phase of the
// case's motion. One timed iteration steps one set with plStepInstances and the other set one by one — the order
// alternating from one iteration to the next, so both see the same machine — until S seconds (default 0.5) have gone
// and at least 5 iterations ran; each number is the median over the iterations of (the call's time) / n. Both sets
// get the same inputs, so after the run their outputs are compared bit for bit ("bit_identical").
// "batch_vs_single_step" divides the batch's per-instance time by the one-by-one time of n = 1 for the same asset and
// workers (the single-instance step of the same run); the target is <= 0.25 at n = 64. Two-worker entries
// also divide by the one-worker single step of the same run ("batch_vs_single_step_1_worker", when --workers has 1
// first). Each entry states the kernels: "single_isa" (the context's, plInstance_Step) and "batch_isa" (what
// plStepInstances chose on this CPU; --batch-isa avx2 caps it at the AVX2 twins for a comparison), plus the median
// and the minimum over the iterations (the minimum is the least disturbed by other processes) and the load average
// before and after the run (/proc/loadavg). --rounds R (default 1) runs the whole sweep R times and reports, per entry,
// the median over the rounds of each round's median (and the least minimum), the ratios from those medians: on a shared
// machine another process busy for a few seconds then spoils one round of a case, not the case.
// Beside them, the compute floor of the same run (fma_peak_gmacs, step_macs, compute_floor_us_per_instance,
// floor_vs_single_step_1_worker; "The compute floor" below): how close to the target any batching could come.
// --clock cpu is this thread's CPU time: with two workers it leaves out the helper's share, so wall (the default) is
// the clock for every comparison here.
#define _POSIX_C_SOURCE 200809L
#include "asset.h"
#include "bench_support.h"
#include "kernels_batch.h"
#include "pleat/pleat.h"
#include "step_phases.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if defined( __x86_64__ ) && ( defined( __GNUC__ ) || defined( __clang__ ) )
#include <immintrin.h>

// --body-contact on|fast|off (the crowd sweep's instances; default on, plInstanceDef's default): the full contact runs
// per instance and is not batched, the fast one is batched in lanes (pleat.h BODY CONTACT).
static int g_crowdContact = PLEAT_BODY_CONTACT_ON;
#define CROWD_FMA_PROBE 1
#endif

// --only batch|single (for a profiler: perf then sees one side alone): the other set is not stepped, its time is 0
// and bit_identical is not checked (reported null).
static int g_crowdOnly = 0; // 0 both, 'b' batch, 's' single

#define CROWD_MAX_ASSETS 8
#define CROWD_MAX_COUNTS 8
#define CROWD_MAX_ITERATIONS 4000
#define CROWD_MAX_ROUNDS 15

typedef struct CrowdResult
{
	const char* label;
	uint32_t workers, count, iterations;
	double batch_us, single_us;         // per instance, medians
	double batch_min_us, single_min_us; // per instance, minima
	int bit_identical;
	int all_ok;
	double phase_us[PLEAT_BATCH_PHASE_COUNT]; // pleat_bench_crowd_phases: the batch's stages, µs per instance (means)
} CrowdResult;

static uint32_t ParseList( const char* text, uint32_t* out, uint32_t capacity )
{
	uint32_t n = 0;
	while ( *text != '\0' && n < capacity )
	{
		char* end;
		out[n++] = (uint32_t)strtoul( text, &end, 10 );
		text = *end == ',' ? end + 1 : end;
		if ( end == text && *end != '\0' )
		{
			break;
		}
	}
	return n;
}

// ---- The compute floor: what no kernel can beat on this core ----
// A batch reads each weight once, so what is left per instance is arithmetic: the MLPs' multiply-adds (the blocks the
// runtime skips not counted, plLayerMacs) and the blend shapes' D · 3N. The floor is that count at this core's peak
// fp32 FMA rate, measured here with the batch's vector width: 12 independent FMA chains (enough to cover the FMA
// latency on the cores we know) on registers, no memory. "compute_floor_us_per_instance" = MACs / peak / workers,
// and "floor_vs_single_step_1_worker" = floor / the one-worker single step of the same run: where the floor alone is
// above the target (0.25 at n = 64), no batching reaches it with those workers.
#if defined( CROWD_FMA_PROBE )
#define CROWD_FMA_CHAINS 12
__attribute__( ( target( "avx2,fma" ) ) ) static float FmaChains8( uint64_t rounds )
{
	__m256 acc[CROWD_FMA_CHAINS];
	const __m256 m = _mm256_set1_ps( 0.999999f ), c = _mm256_set1_ps( 1e-7f );
	for ( int i = 0; i < CROWD_FMA_CHAINS; ++i )
		acc[i] = _mm256_set1_ps( (float)i );
	for ( uint64_t r = 0; r < rounds; ++r )
		for ( int i = 0; i < CROWD_FMA_CHAINS; ++i )
			acc[i] = _mm256_fmadd_ps( acc[i], m, c );
	__m256 sum = acc[0];
	for ( int i = 1; i < CROWD_FMA_CHAINS; ++i )
		sum = _mm256_add_ps( sum, acc[i] );
	return _mm256_cvtss_f32( sum );
}

__attribute__( ( target( "avx512f" ) ) ) static float FmaChains16( uint64_t rounds )
{
	__m512 acc[CROWD_FMA_CHAINS];
	const __m512 m = _mm512_set1_ps( 0.999999f ), c = _mm512_set1_ps( 1e-7f );
	for ( int i = 0; i < CROWD_FMA_CHAINS; ++i )
		acc[i] = _mm512_set1_ps( (float)i );
	for ( uint64_t r = 0; r < rounds; ++r )
		for ( int i = 0; i < CROWD_FMA_CHAINS; ++i )
			acc[i] = _mm512_fmadd_ps( acc[i], m, c );
	__m512 sum = acc[0];
	for ( int i = 1; i < CROWD_FMA_CHAINS; ++i )
		sum = _mm512_add_ps( sum, acc[i] ); // every chain live, or the compiler drops them
	return _mm512_reduce_add_ps( sum );
}
#endif

static volatile float g_fmaSink;

// Peak fp32 multiply-adds per µs of this thread at `lanes` (8: AVX2 + FMA, 16: AVX-512), the best of 7 runs of
// 12.6 M FMAs each (a few ms; the best is the least disturbed by other processes), after one that wakes the clock up;
// 0 where this build or CPU cannot run them.
static double MeasureFmaPeakMacsPerUs( uint32_t lanes )
{
#if defined( CROWD_FMA_PROBE )
	if ( lanes == 16 ? !__builtin_cpu_supports( "avx512f" )
					 : !( __builtin_cpu_supports( "avx2" ) && __builtin_cpu_supports( "fma" ) ) )
		return 0.0;
	const uint64_t rounds = 1u << 20;
	double best = 0.0;
	for ( int run = 0; run < 8; ++run )
	{
		double t0 = BenchNowUs();
		g_fmaSink = lanes == 16 ? FmaChains16( rounds ) : FmaChains8( rounds );
		double us = BenchNowUs() - t0;
		double rate = (double)rounds * CROWD_FMA_CHAINS * lanes / us;
		best = run > 0 && rate > best ? rate : best; // run 0 warms the clock up
	}
	return best;
#else
	(void)lanes;
	return 0.0;
#endif
}

// The MLP and blend-shape multiply-adds of one step of the asset at `path` (0 if it cannot be read).
static double AssetStepMacs( const char* path )
{
	size_t size = 0;
	uint8_t* bytes = BenchReadFile( path, &size );
	plAssetData a;
	double macs = 0.0;
	if ( bytes != NULL && plAssetData_Parse( bytes, size, 0, &a ) == PLEAT_RESULT_OK )
	{
		for ( uint32_t i = 0; i < a.lp_layer_count; ++i )
			macs += (double)plLayerMacs( &a.lp[i] );
		for ( uint32_t i = 0; i < a.dec_layer_count; ++i )
			macs += (double)plLayerMacs( &a.dec[i] );
		macs += (double)a.blend_count * 3.0 * a.vertex_count;
	}
	free( bytes );
	return macs;
}

// The widest kernel set every context of the run may take (--batch-isa avx2: AVX2).
static plKernelSet g_maxIsa = PLEAT_KERNEL_SET_AVX512;

// Steps set a with plStepInstances and set b one by one (order by iteration parity), n instances each.
static int RunCrowd( const char* path, const BenchMotion* motion, uint32_t workers, BenchTwoWorkers* pool, uint32_t n,
					 double seconds, CrowdResult* result )
{
	plContextDef def = plDefaultContextDef();
	def.max_isa = g_maxIsa;
	if ( workers == 2 )
	{
		BenchTwoWorkers_Install( pool, &def );
	}
	plContext context;
	if ( plCreateContext( &def, &context ) != PLEAT_RESULT_OK )
	{
		return 0;
	}
	plAssetDef adef = plDefaultAssetDef();
	adef.path = path;
	plAsset asset;
	plAssetInfo info;
	if ( plLoadAsset( context, &adef, &asset ) != PLEAT_RESULT_OK || plAsset_GetInfo( asset, &info ) != PLEAT_RESULT_OK )
	{
		plDestroyContext( context );
		return 0;
	}
	plInstance* sets = (plInstance*)calloc( 2 * (size_t)n, sizeof( plInstance ) );
	plFrameInput* inputs = (plFrameInput*)calloc( n, sizeof( plFrameInput ) );
	plResult* results = (plResult*)calloc( n, sizeof( plResult ) );
	double* batch_samples = (double*)calloc( CROWD_MAX_ITERATIONS, sizeof( double ) );
	double* single_samples = (double*)calloc( CROWD_MAX_ITERATIONS, sizeof( double ) );
	int ok = sets != NULL && inputs != NULL && results != NULL && batch_samples != NULL && single_samples != NULL;
	for ( uint32_t i = 0; ok && i < 2 * n; ++i )
	{
		uint32_t k = i % n;
		float beta[PLEAT_MAX_BETAS];
		memcpy( beta, motion->beta, sizeof( beta ) );
		beta[0] += -1.5f + 3.0f * (float)k / (float)( n > 1 ? n - 1 : 1 ); // different bodies, the same in a and b
		beta[1] += ( k % 3 ) * 0.5f - 0.5f;
		plInstanceDef idef = plDefaultInstanceDef();
		idef.asset = asset;
		idef.beta = beta;
		idef.beta_count = motion->beta_count < info.beta_count ? motion->beta_count : info.beta_count;
		idef.engine_joint_count = motion->joint_count;
		idef.body_contact = g_crowdContact;
		ok = idef.beta_count >= 2 && plCreateInstance( context, &idef, &sets[i] ) == PLEAT_RESULT_OK;
	}
	uint32_t frame = 0, iterations = 0;
	double started = BenchNowUs();
	result->all_ok = ok;
	while ( ok && iterations < CROWD_MAX_ITERATIONS )
	{
		for ( uint32_t k = 0; k < n; ++k )
		{
			inputs[k] = BenchMotionFrame( motion, ( frame + 37u * k ) % motion->frame_count );
		}
		double batch_us = 0.0, single_us = 0.0;
		for ( int pass = 0; pass < 2; ++pass )
		{
			int batch = ( pass == 0 ) == ( iterations % 2 == 0 );
			if ( g_crowdOnly != 0 && g_crowdOnly != ( batch ? 'b' : 's' ) )
			{
				continue;
			}
			double t0 = BenchNowUs();
			if ( batch )
			{
				result->all_ok &= plStepInstances( context, sets, inputs, NULL, results, n ) >= 0;
				batch_us = BenchNowUs() - t0;
			}
			else
			{
				for ( uint32_t k = 0; k < n; ++k )
				{
					result->all_ok &= plInstance_Step( sets[n + k], &inputs[k], NULL ) >= 0;
				}
				single_us = BenchNowUs() - t0;
			}
		}
		frame += 1;
		if ( frame <= 2 )
		{
#if defined( PLEAT_STEP_PHASES )
			plBatchPhaseReset();
#endif
			continue; // warm-up: first steps, caches, page faults
		}
		batch_samples[iterations] = batch_us / n;
		single_samples[iterations] = single_us / n;
		iterations += 1;
		if ( iterations >= 5 && BenchNowUs() - started > seconds * 1e6 )
		{
			break;
		}
	}
	int identical = ok && g_crowdOnly == 0;
	for ( uint32_t k = 0; identical && k < n; ++k )
	{
		const float *pa, *pb, *na, *nb;
		plInstance_GetPositions( sets[k], &pa, NULL );
		plInstance_GetPositions( sets[n + k], &pb, NULL );
		plInstance_GetNormals( sets[k], &na, NULL );
		plInstance_GetNormals( sets[n + k], &nb, NULL );
		identical = memcmp( pa, pb, (size_t)info.vertex_count * 12 ) == 0 &&
					memcmp( na, nb, (size_t)info.vertex_count * 12 ) == 0;
	}
	result->workers = workers;
	result->count = n;
	result->iterations = iterations;
	result->batch_us = BenchMedian( batch_samples, iterations ); // sorts: [0] is the minimum then
	result->single_us = BenchMedian( single_samples, iterations );
	result->batch_min_us = iterations > 0 ? batch_samples[0] : 0.0;
	result->single_min_us = iterations > 0 ? single_samples[0] : 0.0;
	result->bit_identical = identical;
#if defined( PLEAT_STEP_PHASES )
	for ( int p = 0; p < PLEAT_BATCH_PHASE_COUNT; ++p )
	{
		result->phase_us[p] = iterations > 0 ? g_plBatchPhaseUs[p] / ( (double)iterations * n ) : 0.0;
	}
#endif
	free( sets );
	free( inputs );
	free( results );
	free( batch_samples );
	free( single_samples );
	plDestroyContext( context );
	return ok;
}


// ---- --scene: the budget policy on a scene of many characters (docs/scene-budget.md) ----

#define SCENE_MAX_TIERS 8
#define SCENE_MAX_BUDGETS 12

// --report-costs: every frame's measured cost goes back to the scene (plScene_ReportFrameCost), which then corrects
// its cost model on the fly; without it the scene plans with the calibrated costs as they are.
static int g_reportCosts = 0;
// --workers 2: the scene's context gets the two-worker task system (the crowd step and the characters' finishing
// split over both), and every cost, calibration included, is wall time on two cores.
static BenchTwoWorkers* g_scenePool = NULL;

typedef struct SceneRig
{
	plContext context;
	plAsset tiers[SCENE_MAX_TIERS];
	uint32_t tier_count;
	plScene scene;
	uint32_t characters;
	plFrameInput* inputs;
} SceneRig;

// A context with the tiers loaded (one thread unless --workers 2: the budget is "µs of one core").
static int SceneRig_Load( SceneRig* rig, const char* const* paths, uint32_t tier_count )
{
	memset( rig, 0, sizeof( *rig ) );
	plContextDef def = plDefaultContextDef();
	def.max_isa = g_maxIsa;
	if ( g_scenePool != NULL )
	{
		BenchTwoWorkers_Install( g_scenePool, &def );
	}
	if ( plCreateContext( &def, &rig->context ) != PLEAT_RESULT_OK )
		return 0;
	rig->tier_count = tier_count;
	for ( uint32_t t = 0; t < tier_count; ++t )
	{
		plAssetDef adef = plDefaultAssetDef();
		adef.path = paths[t];
		if ( plLoadAsset( rig->context, &adef, &rig->tiers[t] ) != PLEAT_RESULT_OK )
			return 0;
	}
	return 1;
}

// A scene of n characters (β spread, distances 2..40 m: importance = 1 / distance², screen coverage).
static int SceneRig_Scene( SceneRig* rig, const plSceneDef* def_in, const BenchMotion* motion, uint32_t n )
{
	plSceneDef def = *def_in;
	def.tiers = rig->tiers;
	def.tier_count = rig->tier_count;
	def.character_capacity = n;
	if ( plCreateScene( rig->context, &def, &rig->scene ) != PLEAT_RESULT_OK )
		return 0;
	rig->characters = n;
	for ( uint32_t i = 0; i < n; ++i )
	{
		float beta[PLEAT_MAX_BETAS];
		memcpy( beta, motion->beta, sizeof( beta ) );
		beta[0] += -1.5f + 3.0f * (float)( ( i * 37 ) % n ) / (float)( n > 1 ? n - 1 : 1 );
		plCharacterDef cdef = plDefaultCharacterDef();
		cdef.beta = beta;
		cdef.beta_count = motion->beta_count;
		cdef.engine_joint_count = motion->joint_count;
		float distance = 2.0f + 38.0f * (float)i / (float)( n > 1 ? n - 1 : 1 );
		cdef.importance = 1.0f / ( distance * distance );
		uint32_t id;
		if ( plScene_AddCharacter( rig->scene, &cdef, &id ) < 0 )
			return 0;
	}
	rig->inputs = (plFrameInput*)calloc( n, sizeof( plFrameInput ) );
	return rig->inputs != NULL;
}

// Steps the scene `frames` times (after 60 untimed frames: the first switches and the cost correction settle); per-frame µs into samples. Returns 0 on a failed step.
// Detail changes per timed frame in the last SceneRig_Run (a policy that thrashes pays for fades all the time).
static double g_switchesPerFrame = 0.0;

static int SceneRig_Run( SceneRig* rig, const BenchMotion* motion, uint32_t frames, double* samples,
						 plScenePlan* out_plan )
{
	plDetail* last = (plDetail*)calloc( rig->characters, sizeof( plDetail ) );
	uint64_t switches = 0;
	if ( last == NULL )
		return 0;
	for ( uint32_t f = 0; f < frames + 60; ++f )
	{
		for ( uint32_t i = 0; i < rig->characters; ++i )
		{
			rig->inputs[i] = BenchMotionFrame( motion, ( f + 37u * i ) % motion->frame_count );
			rig->inputs[i].dt_s = 1.0f / 60.0f;
		}
		double t0 = BenchNowUs();
		if ( plScene_Step( rig->scene, rig->inputs, NULL, NULL, rig->characters ) < 0 )
			return 0;
		double us = BenchNowUs() - t0;
		if ( g_reportCosts )
			plScene_ReportFrameCost( rig->scene, (float)us ); // the engine's feedback: the plan follows this machine
		if ( f >= 60 )
			samples[f - 60] = us;
		for ( uint32_t i = 0; i < rig->characters; ++i )
		{
			plDetail d;
			plScene_GetDetail( rig->scene, i, &d, NULL, NULL );
			switches += f >= 60 && ( d.tier != last[i].tier || d.network_rate_hz != last[i].network_rate_hz );
			last[i] = d;
		}
	}
	free( last );
	g_switchesPerFrame = frames > 0 ? (double)switches / frames : 0.0;
	plScene_GetPlan( rig->scene, out_plan );
	return 1;
}

static void SceneRig_Free( SceneRig* rig )
{
	plDestroyContext( rig->context );
	free( rig->inputs );
}

// One detail for every character: the measured µs per character (the calibration of the scene's costs).
static double MeasureDetail( const char* const* paths, uint32_t tier_count, const BenchMotion* motion, uint32_t n,
							 uint32_t frames, plDetail detail, const float* rates, uint32_t rate_count )
{
	SceneRig rig;
	plSceneDef def = plDefaultSceneDef();
	def.network_rates_hz = rates;
	def.network_rate_count = rate_count;
	double result = -1.0;
	double* samples = (double*)calloc( frames, sizeof( double ) );
	plScenePlan plan;
	if ( SceneRig_Load( &rig, paths, tier_count ) && SceneRig_Scene( &rig, &def, motion, n ) )
	{
		for ( uint32_t i = 0; i < n; ++i )
			plScene_SetOverride( rig.scene, i, &detail );
		if ( SceneRig_Run( &rig, motion, frames, samples, &plan ) )
		{
			// The mean, not the median: at a reduced rate one frame in k runs the networks, so the median frame would
			// be a cheap one; the plan budgets the average cost per frame.
			double sum = 0.0;
			for ( uint32_t f = 0; f < frames; ++f )
				sum += samples[f];
			result = sum / frames / n;
		}
	}
	free( samples );
	SceneRig_Free( &rig );
	return result;
}

static int RunScene( int argc, char** argv )
{
	const char* case_path = NULL;
	const char* out_path = NULL;
	const char* tier_paths[SCENE_MAX_TIERS];
	uint32_t tier_count = 0, characters = 100, frames = 120, budget_count = 0, workers = 1;
	float errors[SCENE_MAX_TIERS + 1] = { 0 };
	uint32_t error_count = 0;
	double budgets[SCENE_MAX_BUDGETS];
	for ( int i = 1; i + 1 < argc; i += 2 )
	{
		if ( strcmp( argv[i], "--scene" ) == 0 || strcmp( argv[i], "--report-costs" ) == 0 )
		{
			g_reportCosts = g_reportCosts || argv[i][2] == 'r';
			i -= 1; // a flag without a value
			continue;
		}
		if ( strcmp( argv[i], "--case" ) == 0 )
			case_path = argv[i + 1];
		else if ( strcmp( argv[i], "--out" ) == 0 )
			out_path = argv[i + 1];
		else if ( strcmp( argv[i], "--tier" ) == 0 && tier_count < SCENE_MAX_TIERS )
			tier_paths[tier_count++] = argv[i + 1];
		else if ( strcmp( argv[i], "--characters" ) == 0 )
			characters = (uint32_t)strtoul( argv[i + 1], NULL, 10 );
		else if ( strcmp( argv[i], "--frames" ) == 0 )
			frames = (uint32_t)strtoul( argv[i + 1], NULL, 10 );
		else if ( strcmp( argv[i], "--workers" ) == 0 )
			workers = (uint32_t)strtoul( argv[i + 1], NULL, 10 );
		else if ( strcmp( argv[i], "--clock" ) == 0 )
			g_benchClock = strcmp( argv[i + 1], "cpu" ) == 0 ? CLOCK_THREAD_CPUTIME_ID : CLOCK_MONOTONIC;
		else if ( strcmp( argv[i], "--tier-errors" ) == 0 )
		{
			char* p = argv[i + 1];
			while ( *p != '\0' && error_count <= SCENE_MAX_TIERS )
			{
				errors[error_count++] = strtof( p, &p );
				p += *p == ',';
			}
		}
		else if ( strcmp( argv[i], "--budgets" ) == 0 )
		{
			char* p = argv[i + 1];
			while ( *p != '\0' && budget_count < SCENE_MAX_BUDGETS )
			{
				budgets[budget_count++] = strtod( p, &p );
				p += *p == ',';
			}
		}
		else
		{
			fprintf( stderr, "pleat_bench_crowd --scene: unknown option %s\n", argv[i] );
			return 2;
		}
	}
	BenchMotion motion;
	if ( case_path == NULL || tier_count == 0 || characters == 0 || frames == 0 || budget_count == 0 ||
		 error_count != tier_count + 1 || ( workers != 1 && workers != 2 ) ||
		 ( workers == 2 && g_benchClock != CLOCK_MONOTONIC ) || !BenchReadMotion( case_path, &motion ) )
	{
		fprintf( stderr, "usage: pleat_bench_crowd --scene --case case.bin --tier T0.pleat [--tier T1.pleat ...] "
						 "--tier-errors e0,..,lbs --budgets B0,B1,.. [--characters 100] [--frames 120] [--clock cpu] "
						 "[--workers 1|2 (2: wall clock only)] [--out scene.json]\n" );
		return 2;
	}
	static BenchTwoWorkers pool;
	if ( workers == 2 )
	{
		if ( !BenchTwoWorkers_Start( &pool ) )
			return 1;
		g_scenePool = &pool;
	}
	// Calibration: each tier at its full rate and at the lowest rate, and LBS-only, on this machine, in this run.
	const float rates[2] = { 30.0f, 15.0f };
	float cost[SCENE_MAX_TIERS], skin[SCENE_MAX_TIERS], stream[SCENE_MAX_TIERS];
	uint32_t calibration_frames = frames / 2 > 20 ? frames / 2 : 20;
	for ( uint32_t t = 0; t < tier_count; ++t )
	{
		double full = MeasureDetail( tier_paths, tier_count, &motion, characters, calibration_frames,
									 ( plDetail ){ (int32_t)t, 0.0f, 0 }, rates, 2 );
		double slow = MeasureDetail( tier_paths, tier_count, &motion, characters, calibration_frames,
									 ( plDetail ){ (int32_t)t, 15.0f, 0 }, rates, 2 );
		double lone = MeasureDetail( tier_paths, tier_count, &motion, 1, calibration_frames * 4,
									 ( plDetail ){ (int32_t)t, 0.0f, 0 }, rates, 2 );
		if ( full <= 0.0 || slow <= 0.0 || lone <= 0.0 )
			return 1;
		cost[t] = (float)full;
		// cost(15 Hz at 60 fps) = ¼ full + ¾ skin
		skin[t] = (float)( ( slow - 0.25 * full ) / 0.75 > 1.0 ? ( slow - 0.25 * full ) / 0.75 : 1.0 );
		stream[t] = (float)( lone > full ? lone - full : 0.0 );
	}
	double lbs = MeasureDetail( tier_paths, tier_count, &motion, characters, calibration_frames,
								( plDetail ){ -1, 0.0f, 0 }, rates, 2 );
	FILE* out = BenchOpenOutput( "pleat_bench_crowd", out_path );
	if ( out == NULL || lbs <= 0.0 )
		return 1;
	fprintf( out, "{\n  \"clock\": \"%s\",\n  \"workers\": %u,\n  \"characters\": %u,\n  \"frames\": %u,\n"
				  "  \"calibration\": {\n",
			 g_benchClock == CLOCK_MONOTONIC ? "wall" : "cpu", workers, characters, frames );
	for ( uint32_t t = 0; t < tier_count; ++t )
		fprintf( out, "    \"tier%u\": {\"path\": \"%s\", \"cost_us\": %.2f, \"skin_cost_us\": %.2f, "
					  "\"stream_cost_us\": %.2f, \"error_mm\": %.2f},\n",
				 t, tier_paths[t], cost[t], skin[t], stream[t], errors[t] );
	fprintf( out, "    \"lbs\": {\"cost_us\": %.2f, \"error_mm\": %.2f}\n  },\n  \"budgets\": [\n", lbs,
			 errors[tier_count] );
	double* samples = (double*)calloc( frames, sizeof( double ) );
	int failed = 0;
	for ( uint32_t b = 0; b < budget_count; ++b )
	{
		SceneRig rig;
		plSceneDef def = plDefaultSceneDef();
		def.tier_cost_us = cost;
		def.tier_skin_cost_us = skin;
		def.tier_stream_cost_us = stream;
		def.tier_error_mm = errors;
		def.lbs_cost_us = (float)lbs;
		def.lbs_error_mm = errors[tier_count];
		def.network_rates_hz = rates;
		def.network_rate_count = 2;
		def.budget_us = (float)budgets[b];
		plScenePlan plan;
		memset( &plan, 0, sizeof( plan ) );
		int ok = SceneRig_Load( &rig, tier_paths, tier_count ) && SceneRig_Scene( &rig, &def, &motion, characters ) &&
				 SceneRig_Run( &rig, &motion, frames, samples, &plan );
		// The details the plan ended on, and the plain (unweighted) mean error over the characters.
		uint32_t counts[SCENE_MAX_TIERS + 1] = { 0 }, reduced = 0;
		double mean_error = 0.0;
		for ( uint32_t i = 0; ok && i < characters; ++i )
		{
			plDetail d;
			plScene_GetDetail( rig.scene, i, &d, NULL, NULL );
			counts[d.tier < 0 ? tier_count : (uint32_t)d.tier] += 1;
			reduced += d.tier >= 0 && d.network_rate_hz > 0.0f;
			mean_error += d.tier < 0 ? errors[tier_count] : errors[d.tier];
		}
		double p90 = 0.0, median = 0.0;
		if ( ok )
		{
			median = BenchMedian( samples, frames );
			p90 = samples[(size_t)( 0.9 * ( frames - 1 ) )];
		}
		fprintf( out, "%s    {\"budget_us\": %.0f, \"frame_median_us\": %.1f, \"frame_p90_us\": %.1f, "
					  "\"planned_us\": %.1f, \"cost_scale\": %.3f, \"within_budget\": %s, \"weighted_error_mm\": %.2f, \"mean_error_mm\": %.2f, "
					  "\"switches_per_frame\": %.2f, \"details\": [",
				 b ? ",\n" : "", budgets[b], median, p90, plan.cost_us, plan.cost_scale,
				 budgets[b] <= 0.0 || median <= budgets[b] ? "true" : "false", plan.weighted_error_mm,
				 mean_error / characters, g_switchesPerFrame );
		for ( uint32_t t = 0; t <= tier_count; ++t )
			fprintf( out, "%s%u", t ? ", " : "", counts[t] );
		fprintf( out, "], \"reduced_rate\": %u, \"ok\": %s}", reduced, ok ? "true" : "false" );
		fflush( out );
		failed |= !ok;
		SceneRig_Free( &rig );
	}
	fprintf( out, "\n  ]\n}\n" );
	BenchCloseOutput( out );
	free( samples );
	BenchFreeMotion( &motion );
	if ( g_scenePool != NULL )
		BenchTwoWorkers_Stop( g_scenePool );
	return failed;
}

int main( int argc, char** argv )
{
	for ( int i = 1; i < argc; ++i )
	{
		if ( strcmp( argv[i], "--scene" ) == 0 )
			return RunScene( argc, argv );
	}
	const char* case_path = NULL;
	const char* out_path = NULL;
	const char* labels[CROWD_MAX_ASSETS];
	const char* paths[CROWD_MAX_ASSETS];
	uint32_t asset_count = 0;
	uint32_t counts[CROWD_MAX_COUNTS] = { 1, 8, 64, 256 }, count_count = 4;
	uint32_t workers[2] = { 1, 2 }, worker_count = 2;
	double seconds = 0.5;
	uint32_t rounds = 1;
	const char* batch_isa_arg = "best";
	for ( int i = 1; i + 1 < argc; i += 2 )
	{
		if ( strcmp( argv[i], "--case" ) == 0 )
			case_path = argv[i + 1];
		else if ( strcmp( argv[i], "--out" ) == 0 )
			out_path = argv[i + 1];
		else if ( strcmp( argv[i], "--counts" ) == 0 )
			count_count = ParseList( argv[i + 1], counts, CROWD_MAX_COUNTS );
		else if ( strcmp( argv[i], "--workers" ) == 0 )
			worker_count = ParseList( argv[i + 1], workers, 2 );
		else if ( strcmp( argv[i], "--seconds" ) == 0 )
			seconds = strtod( argv[i + 1], NULL );
		else if ( strcmp( argv[i], "--rounds" ) == 0 )
			rounds = (uint32_t)strtoul( argv[i + 1], NULL, 10 );
		else if ( strcmp( argv[i], "--clock" ) == 0 )
			g_benchClock = strcmp( argv[i + 1], "cpu" ) == 0 ? CLOCK_THREAD_CPUTIME_ID : CLOCK_MONOTONIC;
		else if ( strcmp( argv[i], "--batch-isa" ) == 0 )
			batch_isa_arg = argv[i + 1];
		else if ( strcmp( argv[i], "--only" ) == 0 )
			g_crowdOnly = argv[i + 1][0] == 'b' ? 'b' : argv[i + 1][0] == 's' ? 's' : 0;
		else if ( strcmp( argv[i], "--body-contact" ) == 0 )
			g_crowdContact = strcmp( argv[i + 1], "fast" ) == 0 ? PLEAT_BODY_CONTACT_FAST
							 : strcmp( argv[i + 1], "off" ) == 0 ? PLEAT_BODY_CONTACT_OFF
																 : PLEAT_BODY_CONTACT_ON;
		else if ( strcmp( argv[i], "--asset" ) == 0 && asset_count < CROWD_MAX_ASSETS )
		{
			char* eq = strchr( argv[i + 1], '=' );
			if ( eq == NULL )
			{
				fprintf( stderr, "pleat_bench_crowd: --asset LABEL=PATH\n" );
				return 2;
			}
			*eq = '\0';
			labels[asset_count] = argv[i + 1];
			paths[asset_count++] = eq + 1;
		}
		else
		{
			fprintf( stderr, "pleat_bench_crowd: unknown option %s\n", argv[i] );
			return 2;
		}
	}
	BenchMotion motion;
	if ( case_path == NULL || asset_count == 0 || !BenchReadMotion( case_path, &motion ) )
	{
		fprintf( stderr, "usage: pleat_bench_crowd --case case.bin --asset LABEL=PATH [...] [--counts 1,8,64,256] "
						 "[--workers 1,2] [--seconds S] [--rounds R] [--clock wall|cpu] [--batch-isa best|avx2] "
						 "[--only batch|single] [--out crowd.json]\n" );
		return 2;
	}
	if ( rounds < 1 || rounds > CROWD_MAX_ROUNDS )
	{
		fprintf( stderr, "pleat_bench_crowd: --rounds takes 1..%d\n", CROWD_MAX_ROUNDS );
		return 2;
	}
	for ( uint32_t w = 0; w < worker_count; ++w )
	{
		if ( workers[w] != 1 && workers[w] != 2 )
		{
			fprintf( stderr, "pleat_bench_crowd: --workers takes 1 and/or 2\n" );
			return 2;
		}
	}
	BenchTwoWorkers pool;

	// The kernel set every number was measured with: the SDK's choice on this CPU, capped at AVX2 by --batch-isa avx2
	// (every context below gets that max_isa). The single-instance kernels are AVX2's in the AVX-512 set too; the
	// batched ones plStepInstances runs are in the set's table (internal: kernels_batch.h).
	g_maxIsa = strcmp( batch_isa_arg, "avx2" ) == 0 ? PLEAT_KERNEL_SET_AVX2 : PLEAT_KERNEL_SET_AVX512;
	plContextDef probe_def = plDefaultContextDef();
	probe_def.max_isa = g_maxIsa;
	plContext probe;
	plKernelSet kernel_set = PLEAT_KERNEL_SET_SCALAR;
	if ( plCreateContext( &probe_def, &probe ) == PLEAT_RESULT_OK )
	{
		plContext_GetKernelSet( probe, &kernel_set );
		plDestroyContext( probe );
	}
	const char* isa = kernel_set != PLEAT_KERNEL_SET_SCALAR ? "avx2+fma+f16c" : "scalar";
	plKernels kernels;
	plChooseKernels( &kernels, kernel_set );
	const char* batch_isa = kernels.batch->isa;
	double load_start = BenchLoadAverage();
	// The compute floor's peak at the batch's vector width (16 lanes where the batched MLP and blend kernels are the
	// AVX-512 ones), and the AVX2 one beside it for the record.
	double peak_avx2 = MeasureFmaPeakMacsPerUs( 8 ), peak_avx512 = MeasureFmaPeakMacsPerUs( 16 );
	double peak = strstr( batch_isa, "avx512f" ) != NULL ? peak_avx512 : peak_avx2;
	double asset_macs[CROWD_MAX_ASSETS];
	for ( uint32_t a = 0; a < asset_count; ++a )
	{
		asset_macs[a] = AssetStepMacs( paths[a] );
	}

	FILE* out = BenchOpenOutput( "pleat_bench_crowd", out_path );
	if ( out == NULL )
	{
		return 1;
	}
	fprintf( out,
			 "{\n  \"isa\": \"%s\",\n  \"batch_isa\": \"%s\",\n  \"clock\": \"%s\",\n  \"seconds_per_case\": %.2f,\n"
			 "  \"rounds\": %u,\n  \"loadavg_start\": %.2f,\n"
			 "  \"fma_peak_gmacs\": {\"avx2_fma\": %.1f, \"avx512f\": %.1f, \"floor_uses\": \"%s\"},\n"
			 "  \"results\": [\n",
			 isa, batch_isa, g_benchClock == CLOCK_MONOTONIC ? "wall" : "cpu", seconds, rounds, load_start,
			 peak_avx2 / 1e3, peak_avx512 / 1e3, peak == peak_avx512 && peak > 0.0 ? "avx512f" : "avx2_fma" );
	// Every round sweeps assets × workers × counts; results[round][asset][workers][count].
	size_t cases = (size_t)asset_count * worker_count * count_count;
	CrowdResult* results = (CrowdResult*)calloc( cases * rounds, sizeof( CrowdResult ) );
	int failed = results == NULL;
	uint32_t rounds_done = 0;
	for ( uint32_t round = 0; round < rounds && !failed; ++round )
	{
		for ( uint32_t a = 0; a < asset_count; ++a )
		{
			for ( uint32_t w = 0; w < worker_count; ++w )
			{
				// The helper thread only while two-worker cases run: idle, it spins and yields, which a one-worker
				// measurement on a small machine would feel.
				if ( workers[w] == 2 && !BenchTwoWorkers_Start( &pool ) )
				{
					continue;
				}
				for ( uint32_t c = 0; c < count_count; ++c )
				{
					CrowdResult* r = &results[round * cases + ( (size_t)a * worker_count + w ) * count_count + c];
					r->label = labels[a];
					if ( !RunCrowd( paths[a], &motion, workers[w], &pool, counts[c], seconds, r ) )
					{
						fprintf( stderr, "pleat_bench_crowd: %s, %u workers, %u instances failed\n", labels[a],
								 workers[w], counts[c] );
						failed = 1;
					}
				}
				if ( workers[w] == 2 )
				{
					BenchTwoWorkers_Stop( &pool );
				}
			}
		}
		rounds_done += !failed;
	}
	// A failed sweep stops the rounds: the complete ones are combined (or what the first one measured).
	uint32_t used = rounds_done > 0 ? rounds_done : 1;
	int first = 1;
	for ( size_t k = 0; k < cases && results != NULL; ++k )
	{
		// The rounds of case k: medians of the per-round medians, the least minimum, all bit-identical and ok.
		CrowdResult r = results[k];
		double batch[CROWD_MAX_ROUNDS], single[CROWD_MAX_ROUNDS], phase[PLEAT_BATCH_PHASE_COUNT][CROWD_MAX_ROUNDS];
		for ( uint32_t round = 0; round < used; ++round )
		{
			const CrowdResult* q = &results[round * cases + k];
			for ( int p = 0; p < PLEAT_BATCH_PHASE_COUNT; ++p )
			{
				phase[p][round] = q->phase_us[p];
			}
			batch[round] = q->batch_us;
			single[round] = q->single_us;
			r.batch_min_us = q->batch_min_us < r.batch_min_us ? q->batch_min_us : r.batch_min_us;
			r.single_min_us = q->single_min_us < r.single_min_us ? q->single_min_us : r.single_min_us;
			r.bit_identical = r.bit_identical && q->bit_identical;
			r.all_ok = r.all_ok && q->all_ok;
			r.iterations += round > 0 ? q->iterations : 0;
		}
		for ( int p = 0; p < PLEAT_BATCH_PHASE_COUNT; ++p )
		{
			r.phase_us[p] = BenchMedian( phase[p], used );
		}
		r.batch_us = BenchMedian( batch, used );
		r.single_us = BenchMedian( single, used );
		results[k] = r;
	}
	for ( size_t k = 0; k < cases && results != NULL; ++k )
	{
		const CrowdResult r = results[k];
		if ( r.count == 0 )
		{
			continue; // a case that did not run (its failure is reported above)
		}
		// The single step of the same asset and workers (n = 1), and of the same asset with one worker.
		size_t asset_base = k - k % ( (size_t)worker_count * count_count );
		size_t workers_base = k - k % count_count;
		double single_step_us = 0.0, single_step_1_worker_us = 0.0;
		for ( uint32_t c = 0; c < count_count; ++c )
		{
			if ( counts[c] == 1 )
			{
				single_step_us = results[workers_base + c].single_us;
				single_step_1_worker_us = workers[0] == 1 ? results[asset_base + c].single_us : 0.0;
			}
		}
		size_t asset_index = k / ( (size_t)worker_count * count_count );
		double floor_us = peak > 0.0 ? asset_macs[asset_index] / peak / r.workers : 0.0;
		fprintf( out,
				 "%s    {\"asset\": \"%s\", \"workers\": %u, \"instances\": %u, \"isa\": \"%s\", "
				 "\"single_isa\": \"%s\", \"batch_isa\": \"%s\", "
				 "\"batch_us_per_instance\": %.2f, \"one_by_one_us_per_instance\": %.2f, "
				 "\"batch_us_per_instance_min\": %.2f, \"one_by_one_us_per_instance_min\": %.2f, "
				 "\"batch_vs_one_by_one\": %.3f, \"batch_vs_single_step\": %.3f, "
				 "\"batch_vs_single_step_1_worker\": %.3f, \"step_macs\": %.0f, "
				 "\"compute_floor_us_per_instance\": %.2f, \"floor_vs_single_step_1_worker\": %.3f, "
				 "\"iterations\": %u, \"rounds\": %u, "
				 "\"bit_identical\": %s, \"all_steps_ok\": %s",
				 first ? "" : ",\n", r.label, r.workers, r.count, isa, isa, r.count > 1 ? batch_isa : isa, r.batch_us,
				 r.single_us, r.batch_min_us, r.single_min_us, r.single_us > 0.0 ? r.batch_us / r.single_us : 0.0,
				 single_step_us > 0.0 ? r.batch_us / single_step_us : 0.0,
				 single_step_1_worker_us > 0.0 ? r.batch_us / single_step_1_worker_us : 0.0, asset_macs[asset_index],
				 floor_us, single_step_1_worker_us > 0.0 ? floor_us / single_step_1_worker_us : 0.0, r.iterations, used,
				 g_crowdOnly != 0 ? "null" : r.bit_identical ? "true" : "false", r.all_ok ? "true" : "false" );
#if defined( PLEAT_STEP_PHASES )
		fprintf( out,
				 ", \"batch_phase_us_per_instance\": {\"prepare\": %.2f, \"networks\": %.2f, \"blend\": %.2f, "
				 "\"geometry\": %.2f, \"finish\": %.2f}",
				 r.phase_us[PLEAT_BATCH_PHASE_PREPARE], r.phase_us[PLEAT_BATCH_PHASE_NETWORKS],
				 r.phase_us[PLEAT_BATCH_PHASE_BLEND], r.phase_us[PLEAT_BATCH_PHASE_GEOMETRY],
				 r.phase_us[PLEAT_BATCH_PHASE_FINISH] );
#endif
		fprintf( out, "}" );
		fflush( out );
		first = 0;
		failed |= ( g_crowdOnly == 0 && !r.bit_identical ) || !r.all_ok;
	}
	free( results );
	fprintf( out, "\n  ],\n  \"loadavg_end\": %.2f\n}\n", BenchLoadAverage() );
	BenchCloseOutput( out );
	BenchFreeMotion( &motion );
	return failed;
}
