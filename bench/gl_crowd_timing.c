// GPU crowd benchmark (not a test): n instances of one asset stepped with plStepInstances in one GL context, the
// networks on the GPU (PLEAT_MLP_BACKEND_GPU) against the networks on the CPU (the SDK's kernels, one worker) with the
// same deformation on the GPU. Per count and backend, per frame (medians over the frames of each kind):
//   gpu_ms           the GPU's busy time in every batch's dispatches, networks and deformation, from GL_TIME_ELAPSED
//                    queries the SDK wraps around them (g_plGlTimeBatches; on alternate frames, as reading them waits);
//   network_gpu_ms   of which the networks' dispatches (0 on the CPU backend): the networks' share of the GPU time;
//   span_ms          from before the call's first GL command to after its last (GL_TIMESTAMP): GPU work and the gaps
//                    while the CPU prepares each batch of 64;
//   wall_ms          the call plus glFinish, untimed frames: pose upload, the CPU's share (validation, forward
//                    kinematics, X_c, on the CPU backend the networks), the GPU's work and the small network read-
//                    backs; the engine draws from the GPU buffers;
//   wall_readback_ms the same with every instance's positions and normals read back to the CPU.
// On Mesa llvmpipe GL_TIME_ELAPSED reads 0 around compute work, so gpu_ms is meaningful on a hardware GPU only.
//
//   pleat_gl_crowd_timing [--frames N] [--counts 1,64,640,4096] [--out FILE.json] ASSET.pleat
//
// It makes its own headless context (the SDK's route: EGL device platform on a GPU, then surfaceless, then OSMesa) and
// steps the instances in host-context mode there; every instance shares the first one's GPU data (gpu_share), so the
// crowd holds one copy of the asset on the GPU and compiles its programs once. docs/gpu.md
// ("Timings") has its numbers; scripts/gpu-bench.sh runs it and writes bench/results/gpu-crowd-*.json.
#define _POSIX_C_SOURCE 200809L
#include "bench_support.h"
#include "gl/gl_context.h"
#include "gl/gl_internal.h"
#include "test_gl_support.h"
#include <stdatomic.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PLEAT_BENCH_MAX_COUNTS 8

typedef struct plCrowdTiming
{
	double gpu_ms;          // the GPU's busy time in the batches' dispatches (GL_TIME_ELAPSED inside the SDK)
	double network_gpu_ms;  // of which the networks' dispatches
	double span_ms;         // first command to last (GL_TIMESTAMP): GPU work and the gaps between batches
	double wall_ms, wall_readback_ms;
	int ok;
} plCrowdTiming;

static plCrowdTiming plTimeCrowd( plContext context, plAsset asset, const plAssetInfo* info, uint32_t count,
								  plMlpBackend backend, uint32_t frames )
{
	plCrowdTiming timing = { 0.0, 0.0, 0.0, 0.0, 0.0, 0 };
	uint32_t n = info->vertex_count, j = info->joint_count;
	plInstance* crowd = calloc( count, sizeof( plInstance ) );
	plFrameInput* inputs = calloc( count, sizeof( plFrameInput ) );
	plStepOutput* outputs = calloc( count, sizeof( plStepOutput ) );
	plResult* results = calloc( count, sizeof( plResult ) );
	float* rotations = malloc( sizeof( float ) * 4 * j * count );
	float* read_back = malloc( sizeof( float ) * 6 * n ); // every instance writes the same block: only the copy counts
	double* gpu = calloc( frames, sizeof( double ) );
	double* network_gpu = calloc( frames, sizeof( double ) );
	double* span = calloc( frames, sizeof( double ) );
	double* wall = calloc( frames, sizeof( double ) );
	double* wall_rb = calloc( frames, sizeof( double ) );
	uint32_t made = 0;
	for ( ; made < count; ++made )
	{
		plInstanceDef def = plDefaultInstanceDef();
		def.asset = asset;
		def.gpu_mode = PLEAT_GPU_MODE_HOST_CONTEXT;
		def.mlp_backend = backend;
		if ( made > 0 )
			def.gpu_share = crowd[0]; // one copy of the asset on the GPU for the whole crowd
		plResult r = plCreateInstance( context, &def, &crowd[made] );
		if ( r != PLEAT_RESULT_OK )
		{
			fprintf( stderr, "instance %u of %u: %s\n", made, count, plResultString( r ) );
			break;
		}
	}
	if ( made == count )
	{
		GLuint queries[2] = { 0, 0 };
		glGenQueries( 2, queries );
		for ( uint32_t k = 0; k < count; ++k )
			outputs[k] = ( plStepOutput ){ read_back, 0, read_back + 3 * (size_t)n, 0, n };
		timing.ok = 1;
		uint32_t timed_frames = 0, wall_frames = 0, wall_rb_frames = 0;
		for ( uint32_t f = 0; f < 3 + 2 * frames && timing.ok; ++f )
		{
			int readback = f >= 3 + frames; // the second half reads everything back
			for ( uint32_t k = 0; k < count; ++k )
				plTestMotion_WalkPose( f, 7.3f * (float)k, 0.4f, j, rotations + 4 * (size_t)j * k, &inputs[k] );
			// The wall-clock frames run without the SDK's per-batch timer queries (reading them waits for the GPU).
			int timed = f >= 3 && f < 3 + frames && ( f & 1u );
			atomic_store( &g_plGlTimeBatches, timed );
			uint64_t network_ns = atomic_load( &g_plGlNetworkNs ), deform_ns = atomic_load( &g_plGlDeformNs );
			double start = BenchNowUs();
			glQueryCounter( queries[0], GL_TIMESTAMP );
			plResult r = plStepInstances( context, crowd, inputs, readback ? outputs : NULL, results, count );
			glQueryCounter( queries[1], GL_TIMESTAMP );
			glFinish();
			double elapsed = BenchNowUs() - start;
			atomic_store( &g_plGlTimeBatches, 0 );
			network_ns = atomic_load( &g_plGlNetworkNs ) - network_ns;
			deform_ns = atomic_load( &g_plGlDeformNs ) - deform_ns;
			GLuint64 t0 = 0, t1 = 0;
			glGetQueryObjectui64v( queries[0], GL_QUERY_RESULT, &t0 );
			glGetQueryObjectui64v( queries[1], GL_QUERY_RESULT, &t1 );
			GLuint64 ns = t1 > t0 ? t1 - t0 : 0;
			if ( r < 0 )
			{
				fprintf( stderr, "plStepInstances: %s\n", plResultString( r ) );
				timing.ok = 0;
			}
			if ( f < 3 )
				continue; // warm-up
			if ( timed )
			{
				gpu[timed_frames] = (double)( network_ns + deform_ns ) / 1e6;
				network_gpu[timed_frames++] = (double)network_ns / 1e6;
			}
			else if ( readback )
				wall_rb[wall_rb_frames++] = elapsed / 1000.0;
			else
			{
				wall[wall_frames++] = elapsed / 1000.0;
				span[wall_frames - 1] = (double)ns / 1e6;
			}
		}
		glDeleteQueries( 2, queries );
		timing.gpu_ms = BenchMedian( gpu, timed_frames );
		timing.network_gpu_ms = BenchMedian( network_gpu, timed_frames );
		timing.span_ms = BenchMedian( span, wall_frames );
		timing.wall_ms = BenchMedian( wall, wall_frames );
		timing.wall_readback_ms = BenchMedian( wall_rb, wall_rb_frames );
	}
	for ( uint32_t k = 0; k < made; ++k )
		plDestroyInstance( crowd[k] );
	free( crowd );
	free( inputs );
	free( outputs );
	free( results );
	free( rotations );
	free( read_back );
	free( gpu );
	free( network_gpu );
	free( span );
	free( wall );
	free( wall_rb );
	return timing;
}

static void* plBenchAlloc( size_t size, size_t align, void* user )
{
	(void)user;
	align = align < 16 ? 16 : align;
	return aligned_alloc( align, ( size + align - 1 ) / align * align );
}

static void plBenchFree( void* ptr, size_t size, void* user )
{
	(void)size;
	(void)user;
	free( ptr );
}

static const char* plCpuModel( char* buffer, size_t size )
{
	snprintf( buffer, size, "unknown" );
	FILE* f = fopen( "/proc/cpuinfo", "r" );
	if ( f == NULL )
		return buffer;
	char line[256];
	while ( fgets( line, sizeof( line ), f ) != NULL )
	{
		if ( strncmp( line, "model name", 10 ) == 0 )
		{
			const char* colon = strchr( line, ':' );
			if ( colon != NULL )
			{
				snprintf( buffer, size, "%s", colon + 2 );
				buffer[strcspn( buffer, "\n" )] = '\0';
			}
			break;
		}
	}
	fclose( f );
	return buffer;
}

// The JSON string value of s (quotes and backslashes escaped, control characters dropped).
static void plJsonString( FILE* out, const char* s )
{
	fputc( '"', out );
	for ( ; s != NULL && *s != '\0'; ++s )
	{
		if ( *s == '"' || *s == '\\' )
			fputc( '\\', out );
		if ( (unsigned char)*s >= 0x20 )
			fputc( *s, out );
	}
	fputc( '"', out );
}

int main( int argc, char** argv )
{
	uint32_t frames = 60, counts[PLEAT_BENCH_MAX_COUNTS] = { 1, 64, 640, 4096 }, count_count = 4;
	const char *asset_path = NULL, *out_path = NULL;
	for ( int i = 1; i < argc; ++i )
	{
		if ( strcmp( argv[i], "--frames" ) == 0 && i + 1 < argc )
			frames = (uint32_t)atoi( argv[++i] );
		else if ( strcmp( argv[i], "--counts" ) == 0 && i + 1 < argc )
		{
			count_count = 0;
			for ( char* s = strtok( argv[++i], "," ); s != NULL && count_count < PLEAT_BENCH_MAX_COUNTS;
				  s = strtok( NULL, "," ) )
				counts[count_count++] = (uint32_t)atoi( s );
		}
		else if ( strcmp( argv[i], "--out" ) == 0 && i + 1 < argc )
			out_path = argv[++i];
		else
			asset_path = argv[i];
	}
	if ( asset_path == NULL || frames == 0 || count_count == 0 )
	{
		fprintf( stderr, "usage: pleat_gl_crowd_timing [--frames N] [--counts 1,64,640,4096] [--out FILE] ASSET\n" );
		return 2;
	}
	plAllocator allocator = { plBenchAlloc, plBenchFree, NULL };
	plGlContext* gl = NULL;
	char report[448] = "";
	if ( plGlContext_Create( PLEAT_GL_HEADLESS_AUTO, &allocator, &gl, report, sizeof( report ) ) != PLEAT_RESULT_OK ||
		 plGlContext_Enter( gl ) != PLEAT_RESULT_OK )
	{
		fprintf( stderr, "no headless GL context: %s\n", report );
		return 1;
	}
	plContextDef context_def = plDefaultContextDef(); // one worker: the CPU networks' peer on the calling thread
	plContext context;
	plAssetDef asset_def = plDefaultAssetDef();
	asset_def.path = asset_path;
	plAsset asset;
	plAssetInfo info;
	if ( plCreateContext( &context_def, &context ) != PLEAT_RESULT_OK ||
		 plLoadAsset( context, &asset_def, &asset ) != PLEAT_RESULT_OK ||
		 plAsset_GetInfo( asset, &info ) != PLEAT_RESULT_OK )
	{
		fprintf( stderr, "cannot load %s\n", asset_path );
		return 1;
	}
	FILE* out = BenchOpenOutput( "pleat_gl_crowd_timing", out_path );
	if ( out == NULL )
		return 1;
	char cpu[256];
	fprintf( out, "{\n  \"benchmark\": \"pleat_gl_crowd_timing\",\n  \"asset\": " );
	plJsonString( out, asset_path );
	fprintf( out, ",\n  \"vertices\": %u,\n  \"frames\": %u,\n  \"gl_vendor\": ", info.vertex_count, frames );
	plJsonString( out, (const char*)glGetString( GL_VENDOR ) );
	fprintf( out, ",\n  \"gl_renderer\": " );
	plJsonString( out, (const char*)glGetString( GL_RENDERER ) );
	fprintf( out, ",\n  \"gl_version\": " );
	plJsonString( out, (const char*)glGetString( GL_VERSION ) );
	fprintf( out, ",\n  \"context\": " );
	plJsonString( out, report );
	fprintf( out, ",\n  \"cpu\": " );
	plJsonString( out, plCpuModel( cpu, sizeof( cpu ) ) );
	fprintf( out, ",\n  \"crowds\": [\n" );
	for ( uint32_t c = 0; c < count_count; ++c )
	{
		plCrowdTiming g = plTimeCrowd( context, asset, &info, counts[c], PLEAT_MLP_BACKEND_GPU, frames );
		plCrowdTiming p = plTimeCrowd( context, asset, &info, counts[c], PLEAT_MLP_BACKEND_PLEAT, frames );
		double share = g.gpu_ms > 0.0 ? g.network_gpu_ms / g.gpu_ms : 0.0;
		const plCrowdTiming* both[2] = { &g, &p };
		fprintf( out, "    {\"instances\": %u, \"ok\": %s, \"networks_share_of_gpu_time\": %.3f", counts[c],
				 g.ok && p.ok ? "true" : "false", share );
		for ( int b = 0; b < 2; ++b )
			fprintf( out,
					 ",\n     \"%s\": {\"gpu_ms\": %.4f, \"network_gpu_ms\": %.4f, \"span_ms\": %.4f, "
					 "\"wall_ms\": %.4f, \"wall_readback_ms\": %.4f}",
					 b == 0 ? "gpu_networks" : "cpu_networks", both[b]->gpu_ms, both[b]->network_gpu_ms,
					 both[b]->span_ms, both[b]->wall_ms, both[b]->wall_readback_ms );
		fprintf( out, "}%s\n", c + 1 < count_count ? "," : "" );
		fflush( out );
		fprintf( stderr,
				 "%5u instances: GPU networks %.3f ms GPU (networks %.3f), %.3f ms wall (%.3f with read-back); "
				 "CPU networks %.3f ms GPU, %.3f ms wall\n",
				 counts[c], g.gpu_ms, g.network_gpu_ms, g.wall_ms, g.wall_readback_ms, p.gpu_ms, p.wall_ms );
	}
	fprintf( out, "  ]\n}\n" );
	BenchCloseOutput( out );
	plDestroyAsset( asset );
	plDestroyContext( context );
	plGlContext_Leave( gl );
	plGlContext_Destroy( gl );
	return 0;
}
