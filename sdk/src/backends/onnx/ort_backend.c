// The optional ONNX Runtime backend for the two MLPs (latent predictor and decoder), see ort_backend.h.
//
// libonnxruntime is opened with dlopen at run time, so the SDK neither links against it nor needs it installed. The
// C API header is fetched at build time by scripts/fetch-ort-header.sh; without it (PLEAT_HAVE_ORT_HEADER unset) this
// file builds to a stub whose every entry returns PLEAT_RESULT_BACKEND_UNAVAILABLE. See docs/onnxruntime.md.
//
// Process-wide state: one library handle, one OrtApi table and one OrtEnv, shared by every plOrtMlp and guarded by a
// mutex. The env is reference counted (released with the last plOrtMlp); the library itself stays mapped once ORT
// has been initialised, because ONNX Runtime does not support being unloaded and reloaded in one Linux process.
//
// Per plOrtMlp: one session (1 intra-op thread, sequential, all graph optimisations), input and output OrtValues
// created once over 64-byte aligned buffers owned by the instance, and an OrtIoBinding that binds them, so
// plOrtMlp_Run is a copy in, RunWithBinding, a copy out: no per-call name lookup or output allocation on our side.
// (ORT's own working memory comes from ORT's allocator, not the plAllocator; its planner reuses it across runs.)
#include "ort_backend.h"
#include "asset/onnx_model.h"

#if defined( PLEAT_HAVE_ORT_HEADER ) && PLEAT_HAVE_ORT_HEADER && !defined( _WIN32 )

#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

// The official header has one enumerator (1 << 31) that -Wpedantic rejects in C; it is not ours to change.
#if defined( __GNUC__ )
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpedantic"
#endif
#include <onnxruntime_c_api.h>
#if defined( __GNUC__ )
#pragma GCC diagnostic pop
#endif

#define PL_ORT_BUFFER_ALIGN 64

// sizeof( float ) * count below must not overflow for any uint32_t count.
_Static_assert( SIZE_MAX / sizeof( float ) >= UINT32_MAX, "64-bit size_t required by the ONNX Runtime backend" );

struct plOrtMlp
{
	plAllocator allocator;
	const OrtApi* api;
	OrtSession* session;
	OrtMemoryInfo* memory_info;
	OrtValue* input_value;  // [1, input_count] over input
	OrtValue* output_value; // [1, output_count] over output
	OrtIoBinding* binding;
	float* input;  // [input_count], 64-byte aligned, owned
	float* output; // [output_count], 64-byte aligned, owned
	uint32_t input_count;
	uint32_t output_count;
};

static struct
{
	pthread_mutex_t mutex;
	void* library; // dlopen handle; kept once ORT answered GetApi (see top of file)
	const OrtApi* api;
	OrtEnv* env;
	uint32_t env_refs;
	char load_error[256]; // dlerror() of the last candidate that failed to open, for plOrtMlp_DescribeUnavailable
} s_ort = { PTHREAD_MUTEX_INITIALIZER, NULL, NULL, NULL, 0, { 0 } };

// ORT logs through the env; the SDK never prints, so messages are dropped. Failures reach the caller as result codes.
static void plOrt_DiscardLog( void* param, OrtLoggingLevel severity, const char* category, const char* logid,
							  const char* code_location, const char* message )
{
	(void)param;
	(void)severity;
	(void)category;
	(void)logid;
	(void)code_location;
	(void)message;
}

// Consumes the status. Model-shaped failures (bad protobuf, bad graph, unsupported op) become INVALID_ASSET_DATA,
// allocation failures OUT_OF_MEMORY, anything else `otherwise`.
static plResult plOrt_ConsumeStatus( const OrtApi* api, OrtStatus* status, plResult otherwise )
{
	if ( status == NULL )
	{
		return PLEAT_RESULT_OK;
	}
	OrtErrorCode code = api->GetErrorCode( status );
	const char* message = api->GetErrorMessage( status );
	plResult result = otherwise;
	switch ( code )
	{
		case ORT_INVALID_PROTOBUF:
		case ORT_INVALID_GRAPH:
		case ORT_NO_MODEL:
		case ORT_NOT_IMPLEMENTED:
		case ORT_MODEL_REQUIRES_COMPILATION:
			result = PLEAT_RESULT_INVALID_ASSET_DATA;
			break;
		default:
			// ORT reports std::bad_alloc as a runtime exception carrying that text.
			if ( message != NULL && strstr( message, "bad_alloc" ) != NULL )
			{
				result = PLEAT_RESULT_OUT_OF_MEMORY;
			}
			break;
	}
	api->ReleaseStatus( status );
	return result;
}

static void* plOrt_FindSymbol( void* library, const char* name )
{
	dlerror();
	return dlsym( library, name );
}

// The search list of ort_backend.h: `path` alone, or $PLEAT_ONNXRUNTIME_LIBRARY then the two sonames.
static int plOrt_Candidates( const char* path, const char* candidates[3] )
{
	int candidate_count = 0;
	if ( path != NULL )
	{
		candidates[candidate_count++] = path;
	}
	else
	{
		const char* from_env = getenv( "PLEAT_ONNXRUNTIME_LIBRARY" );
		if ( from_env != NULL && from_env[0] != '\0' )
		{
			candidates[candidate_count++] = from_env;
		}
		candidates[candidate_count++] = "libonnxruntime.so";
		candidates[candidate_count++] = "libonnxruntime.so.1";
	}
	return candidate_count;
}

// Opens `path` (or the search list of ort_backend.h) and checks it is ONNX Runtime with our API version.
// Called with the mutex held and no library loaded.
static plResult plOrt_LoadLibrary( const char* path )
{
	const char* candidates[3];
	int candidate_count = plOrt_Candidates( path, candidates );
	s_ort.load_error[0] = '\0';
	for ( int i = 0; i < candidate_count; ++i )
	{
		void* library = dlopen( candidates[i], RTLD_NOW | RTLD_LOCAL );
		if ( library == NULL )
		{
			const char* error = dlerror();
			snprintf( s_ort.load_error, sizeof( s_ort.load_error ), "%s", error != NULL ? error : candidates[i] );
			continue;
		}
		void* symbol = plOrt_FindSymbol( library, "OrtGetApiBase" );
		if ( symbol == NULL )
		{
			// Not ONNX Runtime: nothing of ORT ran, so it is safe to unload.
			dlclose( library );
			continue;
		}
		const OrtApiBase* ( *get_api_base )( void );
		memcpy( &get_api_base, &symbol, sizeof( get_api_base ) ); // object → function pointer, the POSIX way
		const OrtApiBase* base = get_api_base();
		const OrtApi* api = base != NULL ? base->GetApi( ORT_API_VERSION ) : NULL;
		s_ort.library = library; // ORT's static initialisers have run: keep it mapped for the process lifetime
		if ( api == NULL )
		{
			// Older than the header's ORT_API_VERSION: usable by nobody here.
			s_ort.api = NULL;
			return PLEAT_RESULT_BACKEND_UNAVAILABLE;
		}
		s_ort.api = api;
		return PLEAT_RESULT_OK;
	}
	return PLEAT_RESULT_BACKEND_UNAVAILABLE;
}

// Takes a reference on the process-wide env, loading the library first if needed.
static plResult plOrt_Acquire( const char* path, const OrtApi** out_api )
{
	plResult result = PLEAT_RESULT_OK;
	pthread_mutex_lock( &s_ort.mutex );
	if ( s_ort.library == NULL )
	{
		result = plOrt_LoadLibrary( path );
	}
	else if ( path != NULL )
	{
		// One ONNX Runtime per process: another path must name the same file (dlopen then returns the same handle).
		void* other = dlopen( path, RTLD_NOW | RTLD_LOCAL | RTLD_NOLOAD );
		if ( other == NULL )
		{
			result = PLEAT_RESULT_BACKEND_UNAVAILABLE;
		}
		else
		{
			if ( other != s_ort.library )
			{
				result = PLEAT_RESULT_BACKEND_UNAVAILABLE;
			}
			dlclose( other ); // drops the reference RTLD_NOLOAD took
		}
	}
	if ( result == PLEAT_RESULT_OK && s_ort.api == NULL )
	{
		result = PLEAT_RESULT_BACKEND_UNAVAILABLE;
	}
	if ( result == PLEAT_RESULT_OK && s_ort.env == NULL )
	{
		OrtEnv* env = NULL;
		OrtStatus* status = s_ort.api->CreateEnvWithCustomLogger( plOrt_DiscardLog, NULL, ORT_LOGGING_LEVEL_ERROR,
																  "pleat", &env );
		result = plOrt_ConsumeStatus( s_ort.api, status, PLEAT_RESULT_BACKEND_UNAVAILABLE );
		if ( result == PLEAT_RESULT_OK )
		{
			s_ort.env = env;
			s_ort.env_refs = 0;
			plOrt_ConsumeStatus( s_ort.api, s_ort.api->DisableTelemetryEvents( env ), PLEAT_RESULT_OK );
		}
	}
	if ( result == PLEAT_RESULT_OK )
	{
		s_ort.env_refs += 1;
		*out_api = s_ort.api;
	}
	pthread_mutex_unlock( &s_ort.mutex );
	return result;
}

static void plOrt_Release( void )
{
	pthread_mutex_lock( &s_ort.mutex );
	if ( s_ort.env_refs > 0 )
	{
		s_ort.env_refs -= 1;
		if ( s_ort.env_refs == 0 && s_ort.env != NULL )
		{
			s_ort.api->ReleaseEnv( s_ort.env );
			s_ort.env = NULL;
		}
	}
	pthread_mutex_unlock( &s_ort.mutex );
}

// The model's single input (or output) must be a float tensor [1, count]; a symbolic (-1) dimension is accepted.
static plResult plOrt_CheckTensor( const OrtApi* api, OrtTypeInfo* type_info, uint32_t count )
{
	const OrtTensorTypeAndShapeInfo* tensor = NULL;
	plResult result = plOrt_ConsumeStatus( api, api->CastTypeInfoToTensorInfo( type_info, &tensor ),
										   PLEAT_RESULT_INVALID_ASSET_DATA );
	if ( result != PLEAT_RESULT_OK )
	{
		return result;
	}
	if ( tensor == NULL )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA; // a sequence or map, not a tensor
	}
	ONNXTensorElementDataType element_type = ONNX_TENSOR_ELEMENT_DATA_TYPE_UNDEFINED;
	size_t rank = 0;
	result = plOrt_ConsumeStatus( api, api->GetTensorElementType( tensor, &element_type ),
								  PLEAT_RESULT_INVALID_ASSET_DATA );
	if ( result == PLEAT_RESULT_OK )
	{
		result = plOrt_ConsumeStatus( api, api->GetDimensionsCount( tensor, &rank ), PLEAT_RESULT_INVALID_ASSET_DATA );
	}
	if ( result != PLEAT_RESULT_OK )
	{
		return result;
	}
	if ( element_type != ONNX_TENSOR_ELEMENT_DATA_TYPE_FLOAT || rank != 2 )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	int64_t dims[2] = { 0, 0 };
	result = plOrt_ConsumeStatus( api, api->GetDimensions( tensor, dims, 2 ), PLEAT_RESULT_INVALID_ASSET_DATA );
	if ( result != PLEAT_RESULT_OK )
	{
		return result;
	}
	if ( ( dims[0] != 1 && dims[0] != -1 ) || ( dims[1] != (int64_t)count && dims[1] != -1 ) )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}
	return PLEAT_RESULT_OK;
}

// Checks the single input/output against the expected counts and binds the pre-created values by name.
static plResult plOrt_BindEndpoints( plOrtMlp* mlp )
{
	const OrtApi* api = mlp->api;
	size_t input_total = 0;
	size_t output_total = 0;
	plResult result = plOrt_ConsumeStatus( api, api->SessionGetInputCount( mlp->session, &input_total ),
										   PLEAT_RESULT_INVALID_ASSET_DATA );
	if ( result == PLEAT_RESULT_OK )
	{
		result = plOrt_ConsumeStatus( api, api->SessionGetOutputCount( mlp->session, &output_total ),
									  PLEAT_RESULT_INVALID_ASSET_DATA );
	}
	if ( result != PLEAT_RESULT_OK )
	{
		return result;
	}
	if ( input_total != 1 || output_total != 1 )
	{
		return PLEAT_RESULT_INVALID_ASSET_DATA;
	}

	for ( int is_output = 0; is_output < 2 && result == PLEAT_RESULT_OK; ++is_output )
	{
		OrtTypeInfo* type_info = NULL;
		OrtStatus* status = is_output ? api->SessionGetOutputTypeInfo( mlp->session, 0, &type_info )
									  : api->SessionGetInputTypeInfo( mlp->session, 0, &type_info );
		result = plOrt_ConsumeStatus( api, status, PLEAT_RESULT_INVALID_ASSET_DATA );
		if ( result != PLEAT_RESULT_OK )
		{
			break;
		}
		result = plOrt_CheckTensor( api, type_info, is_output ? mlp->output_count : mlp->input_count );
		api->ReleaseTypeInfo( type_info );
	}
	if ( result != PLEAT_RESULT_OK )
	{
		return result;
	}

	OrtAllocator* ort_allocator = NULL;
	result = plOrt_ConsumeStatus( api, api->GetAllocatorWithDefaultOptions( &ort_allocator ),
								  PLEAT_RESULT_BACKEND_UNAVAILABLE );
	if ( result != PLEAT_RESULT_OK )
	{
		return result;
	}
	for ( int is_output = 0; is_output < 2 && result == PLEAT_RESULT_OK; ++is_output )
	{
		char* name = NULL;
		OrtStatus* status = is_output ? api->SessionGetOutputName( mlp->session, 0, ort_allocator, &name )
									  : api->SessionGetInputName( mlp->session, 0, ort_allocator, &name );
		result = plOrt_ConsumeStatus( api, status, PLEAT_RESULT_INVALID_ASSET_DATA );
		if ( result != PLEAT_RESULT_OK )
		{
			break;
		}
		status = is_output ? api->BindOutput( mlp->binding, name, mlp->output_value )
						   : api->BindInput( mlp->binding, name, mlp->input_value );
		result = plOrt_ConsumeStatus( api, status, PLEAT_RESULT_INVALID_ASSET_DATA );
		plOrt_ConsumeStatus( api, api->AllocatorFree( ort_allocator, name ), PLEAT_RESULT_OK );
	}
	return result;
}

static plResult plOrt_CreateSession( plOrtMlp* mlp, const void* onnx_model, size_t onnx_model_size )
{
	const OrtApi* api = mlp->api;
	OrtSessionOptions* options = NULL;
	plResult result = plOrt_ConsumeStatus( api, api->CreateSessionOptions( &options ), PLEAT_RESULT_OUT_OF_MEMORY );
	if ( result != PLEAT_RESULT_OK )
	{
		return result;
	}
	// The host's task system owns parallelism: ORT runs on the calling thread only and never spins.
	OrtStatus* status = api->SetIntraOpNumThreads( options, 1 );
	if ( status == NULL )
		status = api->SetInterOpNumThreads( options, 1 );
	if ( status == NULL )
		status = api->SetSessionExecutionMode( options, ORT_SEQUENTIAL );
	if ( status == NULL )
		status = api->SetSessionGraphOptimizationLevel( options, ORT_ENABLE_ALL );
	if ( status == NULL )
		status = api->AddSessionConfigEntry( options, "session.intra_op.allow_spinning", "0" );
	if ( status == NULL )
		status = api->AddSessionConfigEntry( options, "session.inter_op.allow_spinning", "0" );
	// The bytes are an ONNX protobuf, the only form plOnnxModel_Check walks: ORT must not take them for its own
	// flatbuffer format because of a marker inside them.
	if ( status == NULL )
		status = api->AddSessionConfigEntry( options, "session.load_model_format", "ONNX" );
	result = plOrt_ConsumeStatus( api, status, PLEAT_RESULT_BACKEND_UNAVAILABLE );

	if ( result == PLEAT_RESULT_OK )
	{
		pthread_mutex_lock( &s_ort.mutex );
		OrtEnv* env = s_ort.env;
		pthread_mutex_unlock( &s_ort.mutex );
		status = api->CreateSessionFromArray( env, onnx_model, onnx_model_size, options, &mlp->session );
		// A model ORT cannot load is bad asset data whatever ORT's own code says (ORT_FAIL for some parse errors).
		result = plOrt_ConsumeStatus( api, status, PLEAT_RESULT_INVALID_ASSET_DATA );
		if ( result != PLEAT_RESULT_OK )
		{
			mlp->session = NULL;
		}
	}
	api->ReleaseSessionOptions( options );
	return result;
}

static plResult plOrt_CreateValues( plOrtMlp* mlp )
{
	const OrtApi* api = mlp->api;
	plResult result = plOrt_ConsumeStatus(
		api, api->CreateCpuMemoryInfo( OrtDeviceAllocator, OrtMemTypeDefault, &mlp->memory_info ),
		PLEAT_RESULT_OUT_OF_MEMORY );
	if ( result != PLEAT_RESULT_OK )
	{
		mlp->memory_info = NULL;
		return result;
	}
	const int64_t input_shape[2] = { 1, (int64_t)mlp->input_count };
	const int64_t output_shape[2] = { 1, (int64_t)mlp->output_count };
	result = plOrt_ConsumeStatus( api,
								  api->CreateTensorWithDataAsOrtValue(
									  mlp->memory_info, mlp->input, sizeof( float ) * mlp->input_count, input_shape,
									  2, ONNX_TENSOR_ELEMENT_DATA_TYPE_FLOAT, &mlp->input_value ),
								  PLEAT_RESULT_OUT_OF_MEMORY );
	if ( result != PLEAT_RESULT_OK )
	{
		mlp->input_value = NULL;
		return result;
	}
	result = plOrt_ConsumeStatus( api,
								  api->CreateTensorWithDataAsOrtValue(
									  mlp->memory_info, mlp->output, sizeof( float ) * mlp->output_count,
									  output_shape, 2, ONNX_TENSOR_ELEMENT_DATA_TYPE_FLOAT, &mlp->output_value ),
								  PLEAT_RESULT_OUT_OF_MEMORY );
	if ( result != PLEAT_RESULT_OK )
	{
		mlp->output_value = NULL;
		return result;
	}
	result = plOrt_ConsumeStatus( api, api->CreateIoBinding( mlp->session, &mlp->binding ),
								  PLEAT_RESULT_OUT_OF_MEMORY );
	if ( result != PLEAT_RESULT_OK )
	{
		mlp->binding = NULL;
	}
	return result;
}

static void plOrt_DestroyParts( plOrtMlp* mlp )
{
	const OrtApi* api = mlp->api;
	if ( api != NULL )
	{
		if ( mlp->binding != NULL )
			api->ReleaseIoBinding( mlp->binding );
		if ( mlp->input_value != NULL )
			api->ReleaseValue( mlp->input_value );
		if ( mlp->output_value != NULL )
			api->ReleaseValue( mlp->output_value );
		if ( mlp->memory_info != NULL )
			api->ReleaseMemoryInfo( mlp->memory_info );
		if ( mlp->session != NULL )
			api->ReleaseSession( mlp->session );
		plOrt_Release();
	}
	plFree( &mlp->allocator, mlp->input, sizeof( float ) * mlp->input_count );
	plFree( &mlp->allocator, mlp->output, sizeof( float ) * mlp->output_count );
	plAllocator allocator = mlp->allocator;
	plFree( &allocator, mlp, sizeof( *mlp ) );
}

plResult plOrtMlp_Create( const char* library_path, const void* onnx_model, size_t onnx_model_size,
						  uint32_t input_count, uint32_t output_count, const plAllocator* allocator, plOrtMlp** out )
{
	if ( out == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	*out = NULL;
	if ( onnx_model == NULL || onnx_model_size == 0 || input_count == 0 || output_count == 0 || allocator == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}

	plOrtMlp* mlp = (plOrtMlp*)plAllocZeroed( allocator, sizeof( plOrtMlp ), 16 );
	if ( mlp == NULL )
	{
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	mlp->allocator = *allocator;
	mlp->input_count = input_count;
	mlp->output_count = output_count;
	mlp->input = (float*)plAllocZeroed( allocator, sizeof( float ) * input_count, PL_ORT_BUFFER_ALIGN );
	mlp->output = (float*)plAllocZeroed( allocator, sizeof( float ) * output_count, PL_ORT_BUFFER_ALIGN );
	if ( mlp->input == NULL || mlp->output == NULL )
	{
		plOrt_DestroyParts( mlp );
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}

	const OrtApi* api = NULL;
	plResult result = plOrt_Acquire( library_path, &api );
	if ( result != PLEAT_RESULT_OK )
	{
		plOrt_DestroyParts( mlp ); // api still NULL: no env reference to drop
		return result;
	}
	mlp->api = api;

	// The loader rejected such assets already; checked again because a block used in place is the caller's memory
	// until the session is made, and ONNX Runtime must never be the first to read a model that points outside itself.
	result = plOnnxModel_Check( (const uint8_t*)onnx_model, onnx_model_size ) == PLEAT_ONNX_SELF_CONTAINED
				 ? PLEAT_RESULT_OK
				 : PLEAT_RESULT_INVALID_ASSET_DATA;
	if ( result == PLEAT_RESULT_OK )
	{
		result = plOrt_CreateSession( mlp, onnx_model, onnx_model_size );
	}
	if ( result == PLEAT_RESULT_OK )
	{
		result = plOrt_CreateValues( mlp );
	}
	if ( result == PLEAT_RESULT_OK )
	{
		result = plOrt_BindEndpoints( mlp );
	}
	if ( result != PLEAT_RESULT_OK )
	{
		plOrt_DestroyParts( mlp );
		return result;
	}
	*out = mlp;
	return PLEAT_RESULT_OK;
}

plResult plOrtMlp_Run( plOrtMlp* mlp, const float* input, float* output )
{
	if ( mlp == NULL || input == NULL || output == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	const OrtApi* api = mlp->api;
	memcpy( mlp->input, input, sizeof( float ) * mlp->input_count );
	OrtStatus* status = api->RunWithBinding( mlp->session, NULL, mlp->binding );
	// A model that loaded and type-checked but fails to run (e.g. a shape error deep in the graph) is bad asset data.
	plResult result = plOrt_ConsumeStatus( api, status, PLEAT_RESULT_INVALID_ASSET_DATA );
	if ( result != PLEAT_RESULT_OK )
	{
		return result; // output untouched
	}
	memcpy( output, mlp->output, sizeof( float ) * mlp->output_count );
	return PLEAT_RESULT_OK;
}

void plOrtMlp_Destroy( plOrtMlp* mlp )
{
	if ( mlp != NULL )
	{
		plOrt_DestroyParts( mlp );
	}
}

int plOrtMlp_DescribeUnavailable( const char* library_path, char* out, size_t out_size )
{
	if ( out == NULL || out_size == 0 )
	{
		return 0;
	}
	out[0] = '\0';
	pthread_mutex_lock( &s_ort.mutex );
	int loaded = s_ort.library != NULL;
	int usable = s_ort.api != NULL;
	char load_error[sizeof( s_ort.load_error )];
	memcpy( load_error, s_ort.load_error, sizeof( load_error ) );
	pthread_mutex_unlock( &s_ort.mutex );
	if ( loaded && usable )
	{
		return 0;
	}
	if ( loaded )
	{
		snprintf( out, out_size, "the ONNX Runtime library found is older than C API version %d", ORT_API_VERSION );
		return 1;
	}
	// Not found: say what was tried and how to point the SDK at the library, the one fix an integrator needs.
	const char* candidates[3];
	int candidate_count = plOrt_Candidates( library_path, candidates );
	// The advice first: the log line is bounded, and a long path or dlerror text must not push it out.
	snprintf( out, out_size,
			  "ONNX Runtime library not found; set PLEAT_ONNXRUNTIME_LIBRARY (or plInstanceDef.onnxruntime_library) "
			  "to the full path of libonnxruntime.so (tried %s%s%s%s%s%s; last error: %s)",
			  candidates[0], candidate_count > 1 ? ", " : "", candidate_count > 1 ? candidates[1] : "",
			  candidate_count > 2 ? ", " : "", candidate_count > 2 ? candidates[2] : "",
			  library_path != NULL ? " from plInstanceDef.onnxruntime_library" : "", load_error );
	return 1;
}

#else // no ONNX Runtime header at build time (or Windows, where dlopen is not available): the backend is absent

#include <string.h>

plResult plOrtMlp_Create( const char* library_path, const void* onnx_model, size_t onnx_model_size,
						  uint32_t input_count, uint32_t output_count, const plAllocator* allocator, plOrtMlp** out )
{
	(void)library_path;
	(void)onnx_model;
	(void)onnx_model_size;
	(void)input_count;
	(void)output_count;
	(void)allocator;
	if ( out != NULL )
	{
		*out = NULL;
	}
	return PLEAT_RESULT_BACKEND_UNAVAILABLE;
}

plResult plOrtMlp_Run( plOrtMlp* mlp, const float* input, float* output )
{
	(void)mlp;
	(void)input;
	(void)output;
	return PLEAT_RESULT_BACKEND_UNAVAILABLE;
}

void plOrtMlp_Destroy( plOrtMlp* mlp )
{
	(void)mlp;
}

int plOrtMlp_DescribeUnavailable( const char* library_path, char* out, size_t out_size )
{
	(void)library_path;
	if ( out == NULL || out_size == 0 )
	{
		return 0;
	}
	// The stub cannot load anything; still point at PLEAT_ONNXRUNTIME_LIBRARY's prerequisite, the header.
	static const char message[] = "built without the ONNX Runtime C API header (scripts/fetch-ort-header.sh), so "
								  "PLEAT_ONNXRUNTIME_LIBRARY is not consulted and the backend is absent";
	size_t n = sizeof( message ) < out_size ? sizeof( message ) : out_size;
	memcpy( out, message, n );
	out[n - 1] = '\0';
	return 1;
}

#endif
