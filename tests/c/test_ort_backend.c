// The ONNX Runtime backend (sdk/src/backends/onnx/ort_backend.c) against the real libonnxruntime from the onnxruntime wheel.
//
// usage: test_ort_backend PYTHON DATA_SCRIPT DATA_DIR
// Runs `PYTHON DATA_SCRIPT DATA_DIR` (tests/c/test_ort_data.py: small MLPs built with the `onnx` package, numpy
// float64 outputs, the wheel's library path, a small asset with OXLP/OXDC and a motion); tests that need the data
// skip with a reason when it cannot be made. Built without the ORT header (PLEAT_HAVE_ORT_HEADER=0), only the stub
// behaviour is checked.
//
// Tolerances: MLP outputs (ORT fp32 vs float64 numpy, and vs Pleat's own fp32 kernels): |a − b| ≤ 1e-4 · (1 + |b|).
// Rounding over these depths and widths gives ~1e-6; a wrong weight, bias, transpose or activation gives ≥ 1e-2.
// Instance level (ORT backend vs Pleat backend, 60 frames, autoregressive latent): positions within 1e-5 m and
// latents within 1e-4 · (1 + |z|); the two differ only by fp32 summation order (observed ~1e-6).
#define _POSIX_C_SOURCE 200809L // setenv, posix_memalign
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "allocator.h"
#include "jobs.h"
#include "kernels.h"
#include "ort_backend.h"
#include "pleat/pleat.h"

#ifndef PLEAT_HAVE_ORT_HEADER
#define PLEAT_HAVE_ORT_HEADER 0
#endif

#define ORT_TOLERANCE 1e-4

// ---- counting allocator: every byte the backend takes through plAllocator must come back ----

typedef struct CountingAllocator
{
	size_t live_bytes;
	size_t live_blocks;
	size_t fail_after; // 0 = never fail; n = the n-th allocation from now fails
} CountingAllocator;

static void* CountingAlloc( size_t size, size_t align, void* user )
{
	CountingAllocator* counter = (CountingAllocator*)user;
	if ( counter->fail_after != 0 )
	{
		if ( --counter->fail_after == 0 )
		{
			return NULL;
		}
	}
	if ( align < sizeof( void* ) )
	{
		align = sizeof( void* );
	}
	void* ptr = NULL;
	if ( posix_memalign( &ptr, align, size ) != 0 )
	{
		return NULL;
	}
	counter->live_bytes += size;
	counter->live_blocks += 1;
	return ptr;
}

static void CountingFree( void* ptr, size_t size, void* user )
{
	CountingAllocator* counter = (CountingAllocator*)user;
	if ( ptr == NULL )
	{
		return;
	}
	counter->live_bytes -= size;
	counter->live_blocks -= 1;
	free( ptr );
}

static plAllocator MakeAllocator( CountingAllocator* counter )
{
	memset( counter, 0, sizeof( *counter ) );
	plAllocator allocator = { CountingAlloc, CountingFree, counter };
	return allocator;
}

// plOrtMlp_Create must fail with `expected`, set the handle to NULL and keep no memory.
static void ExpectCreateFails( const char* library, const void* model, size_t model_size, uint32_t input_count,
							   uint32_t output_count, plResult expected )
{
	CountingAllocator counter;
	plAllocator allocator = MakeAllocator( &counter );
	plOrtMlp* mlp = (plOrtMlp*)&counter; // must be overwritten with NULL
	assert_int_equal( plOrtMlp_Create( library, model, model_size, input_count, output_count, &allocator, &mlp ),
					  expected );
	assert_null( mlp );
	assert_int_equal( counter.live_bytes, 0 );
}

// ---- test data ----

typedef struct OrtCase
{
	void* model;
	size_t model_size;
	uint32_t input_count;
	uint32_t output_count;
	uint32_t case_count;
	float* inputs;     // [case_count][input_count]
	double* expected;  // [case_count][output_count]
} OrtCase;

typedef struct MlpWeights
{
	plLayer layers[8];
	uint32_t layer_count;
	uint32_t activation;
	float* storage;
} MlpWeights;

typedef struct InstanceCase
{
	void* asset;
	size_t asset_size;
	uint32_t frame_count;
	uint32_t joint_count;
	float beta[10];
	float material[4];
	float* frames; // [frame][J·4 + 3 + 4 + 1]
} InstanceCase;

static char g_data_dir[1024];
static char g_library[1024];
static int g_have_data;
static const char* g_no_data_reason = "no test data";
static OrtCase g_lp;
static OrtCase g_dec;
static MlpWeights g_lp_weights;
static MlpWeights g_dec_weights;
static InstanceCase g_instance;
static int g_have_instance;

static void* ReadFile( const char* path, size_t* size )
{
	FILE* file = fopen( path, "rb" );
	if ( file == NULL )
	{
		return NULL;
	}
	fseek( file, 0, SEEK_END );
	long length = ftell( file );
	fseek( file, 0, SEEK_SET );
	void* bytes = length > 0 ? malloc( (size_t)length + 1 ) : NULL;
	if ( bytes != NULL && fread( bytes, 1, (size_t)length, file ) != (size_t)length )
	{
		free( bytes );
		bytes = NULL;
	}
	fclose( file );
	if ( bytes != NULL )
	{
		( (char*)bytes )[length] = '\0';
		*size = (size_t)length;
	}
	return bytes;
}

static uint32_t ReadU32( const unsigned char* p )
{
	return (uint32_t)p[0] | ( (uint32_t)p[1] << 8 ) | ( (uint32_t)p[2] << 16 ) | ( (uint32_t)p[3] << 24 );
}

static int LoadCase( const char* name, OrtCase* out )
{
	char path[1200];
	snprintf( path, sizeof( path ), "%s/%s.onnx", g_data_dir, name );
	out->model = ReadFile( path, &out->model_size );
	snprintf( path, sizeof( path ), "%s/%s.cases", g_data_dir, name );
	size_t size = 0;
	unsigned char* bytes = (unsigned char*)ReadFile( path, &size );
	if ( out->model == NULL || bytes == NULL || size < 28 || memcmp( bytes, "PLORTC01", 8 ) != 0 )
	{
		free( bytes );
		return 0;
	}
	out->input_count = ReadU32( bytes + 8 );
	out->output_count = ReadU32( bytes + 12 );
	out->case_count = ReadU32( bytes + 24 );
	size_t per_case = 4 * (size_t)out->input_count + 8 * (size_t)out->output_count;
	if ( size != 28 + per_case * out->case_count )
	{
		free( bytes );
		return 0;
	}
	out->inputs = (float*)malloc( 4 * (size_t)out->input_count * out->case_count );
	out->expected = (double*)malloc( 8 * (size_t)out->output_count * out->case_count );
	for ( uint32_t c = 0; c < out->case_count; ++c )
	{
		const unsigned char* p = bytes + 28 + per_case * c;
		memcpy( out->inputs + (size_t)c * out->input_count, p, 4 * (size_t)out->input_count ); // little-endian host
		memcpy( out->expected + (size_t)c * out->output_count, p + 4 * (size_t)out->input_count,
				8 * (size_t)out->output_count );
	}
	free( bytes );
	return 1;
}

static int LoadWeights( const char* name, const OrtCase* c, uint32_t activation, MlpWeights* out )
{
	char path[1200];
	snprintf( path, sizeof( path ), "%s/%s.weights", g_data_dir, name );
	size_t size = 0;
	unsigned char* bytes = (unsigned char*)ReadFile( path, &size );
	if ( bytes == NULL )
	{
		return 0;
	}
	out->storage = (float*)malloc( size );
	out->activation = activation;
	size_t offset = 0;
	size_t float_offset = 0;
	out->layer_count = 0;
	while ( offset + 8 <= size && out->layer_count < 8 )
	{
		uint32_t rows = ReadU32( bytes + offset );
		uint32_t cols = ReadU32( bytes + offset + 4 );
		offset += 8;
		size_t floats = (size_t)rows * cols + rows;
		if ( offset + 4 * floats > size )
		{
			break;
		}
		memcpy( out->storage + float_offset, bytes + offset, 4 * floats );
		plLayer* layer = &out->layers[out->layer_count++];
		layer->weight = out->storage + float_offset;
		layer->weight_fp16 = 0;
		layer->bias = out->storage + float_offset + (size_t)rows * cols;
		layer->in_count = cols;
		layer->out_count = rows;
		offset += 4 * floats;
		float_offset += floats;
	}
	free( bytes );
	return offset == size && out->layer_count > 0 && out->layers[0].in_count == c->input_count &&
		   out->layers[out->layer_count - 1].out_count == c->output_count;
}

static int LoadInstanceCase( InstanceCase* out )
{
	char path[1200];
	snprintf( path, sizeof( path ), "%s/instance.pleat", g_data_dir );
	out->asset = ReadFile( path, &out->asset_size );
	snprintf( path, sizeof( path ), "%s/instance.motion", g_data_dir );
	size_t size = 0;
	unsigned char* bytes = (unsigned char*)ReadFile( path, &size );
	if ( out->asset == NULL || bytes == NULL || size < 16 + 56 || memcmp( bytes, "PLORTM01", 8 ) != 0 )
	{
		free( bytes );
		return 0;
	}
	out->frame_count = ReadU32( bytes + 8 );
	out->joint_count = ReadU32( bytes + 12 );
	memcpy( out->beta, bytes + 16, 40 );
	memcpy( out->material, bytes + 56, 16 );
	size_t per_frame = 4 * ( (size_t)out->joint_count * 4 + 8 );
	if ( size != 72 + per_frame * out->frame_count )
	{
		free( bytes );
		return 0;
	}
	out->frames = (float*)malloc( per_frame * out->frame_count );
	memcpy( out->frames, bytes + 72, per_frame * out->frame_count );
	free( bytes );
	return 1;
}

static void FreeCase( OrtCase* c )
{
	free( c->model );
	free( c->inputs );
	free( c->expected );
	memset( c, 0, sizeof( *c ) );
}

static void PrepareData( const char* python, const char* script, const char* data_dir )
{
	snprintf( g_data_dir, sizeof( g_data_dir ), "%s", data_dir );
	if ( python == NULL || python[0] == '\0' )
	{
		g_no_data_reason = "PLEAT_PYTHON not configured";
		return;
	}
	char command[4096];
	snprintf( command, sizeof( command ), "\"%s\" \"%s\" \"%s\"", python, script, data_dir );
	int status = system( command );
	if ( status != 0 )
	{
		g_no_data_reason = "test_ort_data.py failed (onnx/onnxruntime not installed in PLEAT_PYTHON?)";
		return;
	}
	char path[1200];
	snprintf( path, sizeof( path ), "%s/library.txt", data_dir );
	size_t size = 0;
	char* library = (char*)ReadFile( path, &size );
	if ( library == NULL || size >= sizeof( g_library ) )
	{
		free( library );
		g_no_data_reason = "library.txt missing";
		return;
	}
	memcpy( g_library, library, size + 1 );
	free( library );
	// plOrtMlp_Create( NULL, ... ) searches this variable first.
	setenv( "PLEAT_ONNXRUNTIME_LIBRARY", g_library, 1 );
	if ( !LoadCase( "lp", &g_lp ) || !LoadCase( "dec", &g_dec ) ||
		 !LoadWeights( "lp", &g_lp, PLEAT_ACTIVATION_RELU, &g_lp_weights ) ||
		 !LoadWeights( "dec", &g_dec, PLEAT_ACTIVATION_SILU, &g_dec_weights ) )
	{
		g_no_data_reason = "test data unreadable";
		return;
	}
	g_have_data = 1;
	g_have_instance = LoadInstanceCase( &g_instance );
}

#define REQUIRE_DATA()                                                                                                \
	do                                                                                                                \
	{                                                                                                                 \
		if ( !g_have_data )                                                                                           \
		{                                                                                                             \
			print_message( "skipped: %s\n", g_no_data_reason );                                                       \
			skip();                                                                                                   \
		}                                                                                                             \
	} while ( 0 )

#if PLEAT_HAVE_ORT_HEADER

// A session on the case's model; its memory comes through allocator, which must outlive it.
static plOrtMlp* CreateCaseMlp( const OrtCase* c, const plAllocator* allocator )
{
	plOrtMlp* mlp = NULL;
	assert_int_equal( plOrtMlp_Create( g_library, c->model, c->model_size, c->input_count, c->output_count,
									   allocator, &mlp ),
					  PLEAT_RESULT_OK );
	assert_non_null( mlp );
	return mlp;
}

static void CheckMatchesReference( const OrtCase* c )
{
	CountingAllocator counter;
	plAllocator allocator = MakeAllocator( &counter );
	plOrtMlp* mlp = CreateCaseMlp( c, &allocator );
	float* output = (float*)malloc( 4 * (size_t)c->output_count );
	double worst = 0.0;
	double largest = 0.0;
	for ( uint32_t k = 0; k < c->case_count; ++k )
	{
		assert_int_equal( plOrtMlp_Run( mlp, c->inputs + (size_t)k * c->input_count, output ), PLEAT_RESULT_OK );
		for ( uint32_t o = 0; o < c->output_count; ++o )
		{
			double reference = c->expected[(size_t)k * c->output_count + o];
			double error = fabs( (double)output[o] - reference ) / ( 1.0 + fabs( reference ) );
			worst = error > worst ? error : worst;
			largest = fabs( reference ) > largest ? fabs( reference ) : largest;
			assert_true( isfinite( output[o] ) );
		}
	}
	print_message( "max relative error %.3g over %u cases (|ref| up to %.3g)\n", worst, c->case_count, largest );
	assert_true( worst <= ORT_TOLERANCE );
	assert_true( largest > 0.1 ); // the reference is not trivially zero
	free( output );
	plOrtMlp_Destroy( mlp );
	assert_int_equal( counter.live_bytes, 0 );
	assert_int_equal( counter.live_blocks, 0 );
}

static void relu_mlp_matches_numpy_reference( void** state )
{
	(void)state;
	REQUIRE_DATA();
	CheckMatchesReference( &g_lp );
}

static void silu_mlp_matches_numpy_reference( void** state )
{
	(void)state;
	REQUIRE_DATA();
	CheckMatchesReference( &g_dec );
}

static void wrong_library_path_is_backend_unavailable( void** state )
{
	(void)state;
	REQUIRE_DATA();
	const char* wrong_paths[] = {
		"/nonexistent/libonnxruntime.so", // no such file
		"libm.so.6",                      // a real library that is not ONNX Runtime
		"",                               // dlopen("") is the main program: no OrtGetApiBase in it
	};
	for ( size_t i = 0; i < sizeof( wrong_paths ) / sizeof( wrong_paths[0] ); ++i )
	{
		ExpectCreateFails( wrong_paths[i], g_lp.model, g_lp.model_size, g_lp.input_count, g_lp.output_count,
						   PLEAT_RESULT_BACKEND_UNAVAILABLE );
	}
}

static void corrupt_model_is_invalid_asset_data( void** state )
{
	(void)state;
	REQUIRE_DATA();
	unsigned char garbage[512];
	uint32_t seed = 12345u;
	for ( size_t i = 0; i < sizeof( garbage ); ++i )
	{
		seed = seed * 1664525u + 1013904223u;
		garbage[i] = (unsigned char)( seed >> 24 );
	}
	ExpectCreateFails( g_library, garbage, sizeof( garbage ), g_lp.input_count, g_lp.output_count,
					   PLEAT_RESULT_INVALID_ASSET_DATA );
	// Cut inside the weights: the protobuf is incomplete.
	ExpectCreateFails( g_library, g_lp.model, g_lp.model_size / 2, g_lp.input_count, g_lp.output_count,
					   PLEAT_RESULT_INVALID_ASSET_DATA );
}

static void model_with_other_tensor_sizes_is_invalid_asset_data( void** state )
{
	(void)state;
	REQUIRE_DATA();
	ExpectCreateFails( g_library, g_lp.model, g_lp.model_size, g_lp.input_count + 1, g_lp.output_count,
					   PLEAT_RESULT_INVALID_ASSET_DATA );
	ExpectCreateFails( g_library, g_lp.model, g_lp.model_size, g_lp.input_count, g_lp.output_count - 1,
					   PLEAT_RESULT_INVALID_ASSET_DATA );
	// The decoder model given the latent predictor's sizes.
	ExpectCreateFails( g_library, g_dec.model, g_dec.model_size, g_lp.input_count, g_lp.output_count,
					   PLEAT_RESULT_INVALID_ASSET_DATA );
}

static void invalid_arguments_are_rejected( void** state )
{
	(void)state;
	REQUIRE_DATA();
	CountingAllocator counter;
	plAllocator allocator = MakeAllocator( &counter );
	plOrtMlp* mlp = NULL;
	const void* model = g_lp.model;
	size_t size = g_lp.model_size;
	uint32_t in = g_lp.input_count;
	uint32_t out = g_lp.output_count;
	assert_int_equal( plOrtMlp_Create( g_library, model, size, in, out, &allocator, NULL ),
					  PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plOrtMlp_Create( g_library, NULL, size, in, out, &allocator, &mlp ),
					  PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plOrtMlp_Create( g_library, model, 0, in, out, &allocator, &mlp ),
					  PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plOrtMlp_Create( g_library, model, size, 0, out, &allocator, &mlp ),
					  PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plOrtMlp_Create( g_library, model, size, in, 0, &allocator, &mlp ),
					  PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plOrtMlp_Create( g_library, model, size, in, out, NULL, &mlp ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_null( mlp );

	assert_int_equal( plOrtMlp_Create( g_library, model, size, in, out, &allocator, &mlp ), PLEAT_RESULT_OK );
	float* output = (float*)calloc( out, sizeof( float ) );
	assert_int_equal( plOrtMlp_Run( NULL, g_lp.inputs, output ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plOrtMlp_Run( mlp, NULL, output ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plOrtMlp_Run( mlp, g_lp.inputs, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	free( output );
	plOrtMlp_Destroy( mlp );
	plOrtMlp_Destroy( NULL );
	assert_int_equal( counter.live_bytes, 0 );
}

static void out_of_memory_is_reported_and_nothing_leaks( void** state )
{
	(void)state;
	REQUIRE_DATA();
	// Fail the 1st, 2nd and 3rd allocation in turn: each must give OUT_OF_MEMORY and return everything taken.
	for ( size_t fail_at = 1; fail_at <= 3; ++fail_at )
	{
		CountingAllocator counter;
		plAllocator allocator = MakeAllocator( &counter );
		counter.fail_after = fail_at;
		plOrtMlp* mlp = NULL;
		assert_int_equal( plOrtMlp_Create( g_library, g_lp.model, g_lp.model_size, g_lp.input_count,
										   g_lp.output_count, &allocator, &mlp ),
						  PLEAT_RESULT_OUT_OF_MEMORY );
		assert_null( mlp );
		assert_int_equal( counter.live_bytes, 0 );
	}
}

static void sessions_coexist_and_outlive_env_cycles( void** state )
{
	(void)state;
	REQUIRE_DATA();
	CountingAllocator counter;
	plAllocator allocator = MakeAllocator( &counter );
	float* first = (float*)malloc( 4 * (size_t)g_lp.output_count );
	float* again = (float*)malloc( 4 * (size_t)g_lp.output_count );
	float* dec_out = (float*)malloc( 4 * (size_t)g_dec.output_count );
	for ( int cycle = 0; cycle < 3; ++cycle ) // each cycle releases the shared env and makes a new one
	{
		plOrtMlp* lp = NULL;
		plOrtMlp* dec = NULL;
		assert_int_equal( plOrtMlp_Create( NULL, g_lp.model, g_lp.model_size, g_lp.input_count, g_lp.output_count,
										   &allocator, &lp ),
						  PLEAT_RESULT_OK ); // NULL path: the library is already loaded (or found via the env var)
		assert_int_equal( plOrtMlp_Create( g_library, g_dec.model, g_dec.model_size, g_dec.input_count,
										   g_dec.output_count, &allocator, &dec ),
						  PLEAT_RESULT_OK );
		assert_int_equal( plOrtMlp_Run( lp, g_lp.inputs, first ), PLEAT_RESULT_OK );
		assert_int_equal( plOrtMlp_Run( dec, g_dec.inputs, dec_out ), PLEAT_RESULT_OK );
		assert_int_equal( plOrtMlp_Run( lp, g_lp.inputs, again ), PLEAT_RESULT_OK );
		// Same input, same session: bit-identical (the decoder run between them shares nothing).
		assert_memory_equal( first, again, 4 * (size_t)g_lp.output_count );
		plOrtMlp_Destroy( lp );
		assert_int_equal( plOrtMlp_Run( dec, g_dec.inputs + g_dec.input_count, dec_out ), PLEAT_RESULT_OK );
		for ( uint32_t o = 0; o < g_dec.output_count; ++o )
		{
			double reference = g_dec.expected[g_dec.output_count + o];
			assert_true( fabs( dec_out[o] - reference ) <= ORT_TOLERANCE * ( 1.0 + fabs( reference ) ) );
		}
		plOrtMlp_Destroy( dec );
		assert_int_equal( counter.live_bytes, 0 );
	}
	free( first );
	free( again );
	free( dec_out );
}

static void ort_matches_pleat_mlp_kernels( void** state )
{
	(void)state;
	REQUIRE_DATA();
	const OrtCase* cases[2] = { &g_lp, &g_dec };
	const MlpWeights* weights[2] = { &g_lp_weights, &g_dec_weights };
	for ( int force_scalar = 0; force_scalar < 2; ++force_scalar )
	{
		plKernels kernels;
		plKernelSet set =
			plChooseKernels( &kernels, force_scalar ? PLEAT_KERNEL_SET_SCALAR : PLEAT_KERNEL_SET_AVX512 );
		print_message( "Pleat kernels: %s\n", set != PLEAT_KERNEL_SET_SCALAR ? "AVX2" : "scalar" );
		for ( int m = 0; m < 2; ++m )
		{
			const OrtCase* c = cases[m];
			CountingAllocator counter;
			plAllocator allocator = MakeAllocator( &counter );
			plOrtMlp* mlp = CreateCaseMlp( c, &allocator );
			float* ort_out = (float*)malloc( 4 * (size_t)c->output_count );
			float* pleat_out = (float*)malloc( 4 * (size_t)c->output_count );
			float* scratch = (float*)aligned_alloc( 32, 4 * 256 );
			double worst = 0.0;
			for ( uint32_t k = 0; k < c->case_count; ++k )
			{
				const float* x = c->inputs + (size_t)k * c->input_count;
				plMlpJob job;
				memset( &job, 0, sizeof( job ) );
				job.layers = weights[m]->layers;
				job.layer_count = weights[m]->layer_count;
				job.activation = weights[m]->activation;
				job.input = plMakeConstSpan( x, c->input_count, 4 );
				job.output = plMakeSpan( pleat_out, c->output_count, 4 );
				job.scratch = plMakeSpan( scratch, 256, 4 );
				job.kernels = &kernels;
				assert_int_equal( plMlpJob_Run( &job ), PLEAT_RESULT_OK );
				assert_int_equal( plOrtMlp_Run( mlp, x, ort_out ), PLEAT_RESULT_OK );
				for ( uint32_t o = 0; o < c->output_count; ++o )
				{
					double error = fabs( (double)ort_out[o] - (double)pleat_out[o] ) / ( 1.0 + fabs( pleat_out[o] ) );
					worst = error > worst ? error : worst;
				}
			}
			print_message( "%s: max relative |ORT - Pleat| %.3g\n", m == 0 ? "relu MLP" : "silu MLP", worst );
			assert_true( worst <= ORT_TOLERANCE );
			free( ort_out );
			free( pleat_out );
			free( scratch );
			plOrtMlp_Destroy( mlp );
			assert_int_equal( counter.live_bytes, 0 );
		}
	}
}

// The instance test's asset (OXLP/OXDC sections) in a context that allocates through the counter.
typedef struct LoadedAsset
{
	CountingAllocator counter;
	plContext context;
	plAsset asset;
} LoadedAsset;

// Skips without the instance test's data.
static void LoadInstanceAsset( LoadedAsset* loaded )
{
	REQUIRE_DATA();
	if ( !g_have_instance )
	{
		print_message( "skipped: no instance.pleat (pleat tools not importable by PLEAT_PYTHON?)\n" );
		skip();
	}
	MakeAllocator( &loaded->counter );
	plContextDef cdef = plDefaultContextDef();
	cdef.alloc = CountingAlloc;
	cdef.free = CountingFree;
	cdef.allocator_context = &loaded->counter;
	assert_int_equal( plCreateContext( &cdef, &loaded->context ), PLEAT_RESULT_OK );
	plAssetDef adef = plDefaultAssetDef();
	adef.data = g_instance.asset;
	adef.size = g_instance.asset_size;
	assert_int_equal( plLoadAsset( loaded->context, &adef, &loaded->asset ), PLEAT_RESULT_OK );
}

// Destroys the asset and the context: everything, ORT sessions included, must have come back to the host.
static void UnloadInstanceAsset( const LoadedAsset* loaded )
{
	assert_int_equal( plDestroyAsset( loaded->asset ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyContext( loaded->context ), PLEAT_RESULT_OK );
	assert_int_equal( loaded->counter.live_bytes, 0 );
}

static plResult CreateInstanceWithBackend( const LoadedAsset* loaded, plMlpBackend backend, plInstance* out )
{
	plInstanceDef def = plDefaultInstanceDef();
	def.asset = loaded->asset;
	def.beta = g_instance.beta;
	def.beta_count = 10;
	def.material = g_instance.material;
	def.mlp_backend = backend;
	def.onnxruntime_library = g_library;
	return plCreateInstance( loaded->context, &def, out );
}

static void ort_backend_instance_matches_pleat_backend_over_motion( void** state )
{
	(void)state;
	LoadedAsset loaded;
	LoadInstanceAsset( &loaded );
	plAssetInfo info;
	assert_int_equal( plAsset_GetInfo( loaded.asset, &info ), PLEAT_RESULT_OK );
	assert_true( info.has_onnx_lp && info.has_onnx_decoder );
	assert_int_equal( info.joint_count, g_instance.joint_count );

	plInstance pleat_instance;
	plInstance ort_instance;
	assert_true( CreateInstanceWithBackend( &loaded, PLEAT_MLP_BACKEND_PLEAT, &pleat_instance ) >= 0 );
	assert_true( CreateInstanceWithBackend( &loaded, PLEAT_MLP_BACKEND_ONNXRUNTIME, &ort_instance ) >= 0 );

	float latent_pleat[64];
	float latent_ort[64];
	assert_true( info.latent_count <= 64 );
	double worst_position_m = 0.0;
	double worst_latent = 0.0;
	double largest_latent = 0.0;
	double largest_motion_m = 0.0;
	const float* first_positions = NULL;
	float* reference_start = (float*)malloc( 12 * (size_t)info.vertex_count );
	size_t per_frame = (size_t)g_instance.joint_count * 4 + 8;
	for ( uint32_t f = 0; f < g_instance.frame_count; ++f )
	{
		const float* frame = g_instance.frames + per_frame * f;
		const float* root = frame + (size_t)g_instance.joint_count * 4;
		plFrameInput in;
		memset( &in, 0, sizeof( in ) );
		in.joint_rotations = frame;
		in.joint_count = g_instance.joint_count;
		in.joint_stride_bytes = 16;
		in.root_translation = ( plVec3 ){ root[0], root[1], root[2] };
		in.root_rotation = ( plQuat ){ root[3], root[4], root[5], root[6] };
		in.dt_s = root[7];
		plResult a = plInstance_Step( pleat_instance, &in, NULL );
		plResult b = plInstance_Step( ort_instance, &in, NULL );
		assert_true( a >= 0 );
		assert_int_equal( a, b ); // same notes (e.g. CLAMPED dt) from both
		assert_int_not_equal( a, PLEAT_RESULT_NUMERIC_RESET );
		const float* p_pleat = NULL;
		const float* p_ort = NULL;
		uint32_t n_pleat = 0, n_ort = 0;
		assert_int_equal( plInstance_GetPositions( pleat_instance, &p_pleat, &n_pleat ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_GetPositions( ort_instance, &p_ort, &n_ort ), PLEAT_RESULT_OK );
		assert_int_equal( n_pleat, info.vertex_count );
		assert_int_equal( n_ort, info.vertex_count );
		if ( f == 0 )
		{
			memcpy( reference_start, p_pleat, 12 * (size_t)info.vertex_count );
			first_positions = reference_start;
		}
		for ( uint32_t i = 0; i < 3 * info.vertex_count; ++i )
		{
			assert_true( isfinite( p_ort[i] ) );
			double d = fabs( (double)p_pleat[i] - (double)p_ort[i] );
			worst_position_m = d > worst_position_m ? d : worst_position_m;
			double moved = fabs( (double)p_pleat[i] - (double)first_positions[i] );
			largest_motion_m = moved > largest_motion_m ? moved : largest_motion_m;
		}
		assert_int_equal( plInstance_GetLatent( pleat_instance, latent_pleat, 64 ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_GetLatent( ort_instance, latent_ort, 64 ), PLEAT_RESULT_OK );
		for ( uint32_t l = 0; l < info.latent_count; ++l )
		{
			double d = fabs( (double)latent_pleat[l] - (double)latent_ort[l] ) / ( 1.0 + fabs( latent_pleat[l] ) );
			worst_latent = d > worst_latent ? d : worst_latent;
			largest_latent = fabs( latent_pleat[l] ) > largest_latent ? fabs( latent_pleat[l] ) : largest_latent;
		}
	}
	print_message( "%u frames: max |x_ORT - x_Pleat| = %.3g m, max latent difference %.3g (|z| up to %.3g), "
				   "garment moved up to %.3g m\n",
				   g_instance.frame_count, worst_position_m, worst_latent, largest_latent, largest_motion_m );
	assert_true( worst_position_m <= 1e-5 );
	assert_true( worst_latent <= ORT_TOLERANCE );
	assert_true( largest_latent > 0.1 );   // the networks are doing something
	assert_true( largest_motion_m > 0.1 ); // and the motion moves the garment
	free( reference_start );
	assert_int_equal( plDestroyInstance( ort_instance ), PLEAT_RESULT_OK );
	assert_int_equal( plDestroyInstance( pleat_instance ), PLEAT_RESULT_OK );
	UnloadInstanceAsset( &loaded );
}

static void ort_backend_instance_with_wrong_library_is_backend_unavailable( void** state )
{
	(void)state;
	LoadedAsset loaded;
	LoadInstanceAsset( &loaded );
	plInstanceDef def = plDefaultInstanceDef();
	def.asset = loaded.asset;
	def.mlp_backend = PLEAT_MLP_BACKEND_ONNXRUNTIME;
	def.onnxruntime_library = "/nonexistent/libonnxruntime.so";
	plInstance instance;
	assert_int_equal( plCreateInstance( loaded.context, &def, &instance ), PLEAT_RESULT_BACKEND_UNAVAILABLE );
	assert_false( plInstance_IsValid( instance ) );
	UnloadInstanceAsset( &loaded );
}

#endif // PLEAT_HAVE_ORT_HEADER

// Holds in both builds: with the header, a missing library; without it, always.
static void missing_backend_is_backend_unavailable( void** state )
{
	(void)state;
	static const unsigned char not_a_model[16] = { 1, 2, 3 };
	ExpectCreateFails( "/nonexistent/dir/libonnxruntime.so.1", not_a_model, sizeof( not_a_model ), 4, 4,
					   PLEAT_RESULT_BACKEND_UNAVAILABLE );
#if !PLEAT_HAVE_ORT_HEADER
	float x[4] = { 0 };
	assert_int_equal( plOrtMlp_Run( NULL, x, x ), PLEAT_RESULT_BACKEND_UNAVAILABLE );
	plOrtMlp_Destroy( NULL );
#endif
}

int main( int argc, char** argv )
{
	if ( argc >= 4 )
	{
		PrepareData( argv[1], argv[2], argv[3] );
	}
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( missing_backend_is_backend_unavailable ),
#if PLEAT_HAVE_ORT_HEADER
		cmocka_unit_test( wrong_library_path_is_backend_unavailable ),
		cmocka_unit_test( invalid_arguments_are_rejected ),
		cmocka_unit_test( relu_mlp_matches_numpy_reference ),
		cmocka_unit_test( silu_mlp_matches_numpy_reference ),
		cmocka_unit_test( corrupt_model_is_invalid_asset_data ),
		cmocka_unit_test( model_with_other_tensor_sizes_is_invalid_asset_data ),
		cmocka_unit_test( out_of_memory_is_reported_and_nothing_leaks ),
		cmocka_unit_test( sessions_coexist_and_outlive_env_cycles ),
		cmocka_unit_test( ort_matches_pleat_mlp_kernels ),
		cmocka_unit_test( ort_backend_instance_with_wrong_library_is_backend_unavailable ),
		cmocka_unit_test( ort_backend_instance_matches_pleat_backend_over_motion ),
#endif
	};
	int failed = cmocka_run_group_tests( tests, NULL, NULL );
	FreeCase( &g_lp );
	FreeCase( &g_dec );
	free( g_lp_weights.storage );
	free( g_dec_weights.storage );
	free( g_instance.asset );
	free( g_instance.frames );
	return failed;
}
