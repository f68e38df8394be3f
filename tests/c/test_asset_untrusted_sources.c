// What plLoadAsset is handed may be hostile or simply wrong, and the failure must be clean:
// - a path that names a directory (or anything but a regular file) is PLEAT_RESULT_IO_ERROR, decided before any
//   allocation is sized from the file (a directory's "size" from ftell is LONG_MAX); a FIFO with no writer is refused
//   at once rather than blocking the load forever in open();
// - an embedded ONNX model (OXLP, OXDC) that keeps tensor data outside itself — TensorProto.data_location = EXTERNAL
//   or external_data entries such as location = "secret.bin", in an initializer, a node attribute, a subgraph or a
//   sparse tensor — or that asks ONNX Runtime for session options ("ort_config" metadata) makes the asset
//   PLEAT_RESULT_INVALID_ASSET_DATA with the log item PLEAT_LOG_ASSET_ONNX_REACHES_OUTSIDE: ONNX Runtime would read
//   that file from the working directory and use it as weights. Malformed protobuf is INVALID_ASSET_DATA too.
// The ONNX models are written here byte by byte (protobuf wire format, field numbers of onnx.proto), so the test needs
// neither the onnx package nor ONNX Runtime; a self-contained twin of each model must still load.
#define _POSIX_C_SOURCE 200809L // mkdtemp, mkfifo, alarm
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <signal.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#include "test_common.h"

// ---- a host allocator that remembers the largest request ----

typedef struct plLargestRequest
{
	size_t largest;
	int64_t live_bytes;
} plLargestRequest;

static void* plRecordingAlloc( size_t size, size_t align, void* user )
{
	plLargestRequest* r = (plLargestRequest*)user;
	r->largest = size > r->largest ? size : r->largest;
	if ( size > ( (size_t)1 << 32 ) )
	{
		return NULL;
	}
	void* p = aligned_alloc( align, ( size + align - 1 ) & ~( align - 1 ) );
	if ( p != NULL )
	{
		r->live_bytes += (int64_t)size;
	}
	return p;
}

static void plRecordingFree( void* ptr, size_t size, void* user )
{
	plLargestRequest* r = (plLargestRequest*)user;
	r->live_bytes -= (int64_t)size;
	free( ptr );
}

// ---- defect 4: a directory is not an asset file ----

static void test_loading_a_directory_is_io_error_without_a_huge_allocation( void** state )
{
	(void)state;
	plLargestRequest host = { 0, 0 };
	plTestLog log;
	memset( &log, 0, sizeof( log ) );
	plContextDef cdef = plDefaultContextDef();
	cdef.alloc = plRecordingAlloc;
	cdef.free = plRecordingFree;
	cdef.allocator_context = &host;
	cdef.log = plTestLog_Record;
	cdef.log_context = &log;
	plContext context;
	assert_int_equal( plCreateContext( &cdef, &context ), PLEAT_RESULT_OK );
	plAssetDef adef = plDefaultAssetDef();
	adef.path = "."; // the working directory: always a directory, always openable for reading on POSIX
	plAsset asset;
	assert_int_equal( plLoadAsset( context, &adef, &asset ), PLEAT_RESULT_IO_ERROR );
	assert_false( plAsset_IsValid( asset ) );
	assert_int_equal( log.last_error_item, PLEAT_LOG_ASSET_IO_ERROR );
	// Nothing was sized from the directory (before the fix: a request for LONG_MAX bytes, then OUT_OF_MEMORY).
	assert_true( host.largest < ( (size_t)1 << 20 ) );
	uint64_t live = 1;
	assert_int_equal( plContext_GetLiveBytes( context, &live ), PLEAT_RESULT_OK );
	assert_int_equal( live, 0 );
	assert_int_equal( plDestroyContext( context ), PLEAT_RESULT_OK );
	assert_int_equal( host.live_bytes, 0 );
}

// A FIFO nobody writes to: opening it for reading waits for a writer, for ever. The load must see that it is not a
// regular file without waiting; an alarm turns a load that blocks into a failure of this test instead of a hang.
static char g_fifo_folder[] = "/tmp/pleat_fifo_XXXXXX";
static char g_fifo_path[64];

static void plLoadBlocked( int signal_number )
{
	(void)signal_number;
	static const char message[] = "FAIL: plLoadAsset blocked on a FIFO with no writer\n";
	ssize_t ignored = write( 2, message, sizeof( message ) - 1 );
	(void)ignored;
	unlink( g_fifo_path );
	rmdir( g_fifo_folder );
	_exit( 1 );
}

static void test_loading_a_fifo_without_a_writer_fails_at_once( void** state )
{
	(void)state;
	char* folder = g_fifo_folder;
	char* path = g_fifo_path;
	assert_non_null( mkdtemp( folder ) );
	snprintf( path, sizeof( g_fifo_path ), "%s/garment.pleat", folder );
	assert_int_equal( mkfifo( path, 0600 ), 0 );
	plTestLog log;
	memset( &log, 0, sizeof( log ) );
	plContextDef cdef = plDefaultContextDef();
	cdef.log = plTestLog_Record;
	cdef.log_context = &log;
	plContext context;
	assert_int_equal( plCreateContext( &cdef, &context ), PLEAT_RESULT_OK );
	plAssetDef adef = plDefaultAssetDef();
	adef.path = path;
	plAsset asset;
	void ( *previous )( int ) = signal( SIGALRM, plLoadBlocked );
	alarm( 5 );
	plResult r = plLoadAsset( context, &adef, &asset );
	alarm( 0 );
	signal( SIGALRM, previous );
	assert_int_equal( r, PLEAT_RESULT_IO_ERROR );
	assert_false( plAsset_IsValid( asset ) );
	assert_int_equal( log.last_error_item, PLEAT_LOG_ASSET_IO_ERROR );
	assert_non_null( strstr( log.last_error, path ) );
	assert_non_null( strstr( log.last_error, "not a regular file" ) );
	assert_int_equal( plDestroyContext( context ), PLEAT_RESULT_OK );
	assert_int_equal( unlink( path ), 0 );
	assert_int_equal( rmdir( folder ), 0 );
}

// The regular-file path still works (the same asset written to disk and loaded by path).
static void test_loading_a_regular_file_by_path_still_works( void** state )
{
	(void)state;
	plTestAssetParams p = plTestAsset_DefaultParams();
	plTestAsset* model = plTestAsset_Create( &p );
	size_t size = 0;
	uint8_t* bytes = plTestAsset_Write( model, &size );
	const char* path = "test_asset_untrusted_sources.pleat";
	FILE* f = fopen( path, "wb" );
	assert_non_null( f );
	assert_int_equal( fwrite( bytes, 1, size, f ), size );
	assert_int_equal( fclose( f ), 0 );
	plContextDef cdef = plDefaultContextDef();
	plContext context;
	assert_int_equal( plCreateContext( &cdef, &context ), PLEAT_RESULT_OK );
	plAssetDef adef = plDefaultAssetDef();
	adef.path = path;
	plAsset asset;
	assert_int_equal( plLoadAsset( context, &adef, &asset ), PLEAT_RESULT_OK );
	plAssetInfo info;
	assert_int_equal( plAsset_GetInfo( asset, &info ), PLEAT_RESULT_OK );
	assert_int_equal( info.vertex_count, model->N );
	assert_int_equal( plDestroyContext( context ), PLEAT_RESULT_OK );
	remove( path );
	plTestAsset_FreeBytes( bytes );
	plTestAsset_Destroy( model );
}

// ---- defect 6: ONNX models that reach outside the asset ----

// A protobuf message under construction (wire format: key = field << 3 | wire type; varints little-endian base 128).
typedef struct plPb
{
	uint8_t bytes[8192];
	size_t size;
} plPb;

static void plPb_Varint( plPb* m, uint64_t v )
{
	do
	{
		assert_true( m->size < sizeof( m->bytes ) );
		uint8_t b = (uint8_t)( v & 0x7Fu );
		v >>= 7;
		m->bytes[m->size++] = (uint8_t)( b | ( v != 0 ? 0x80u : 0u ) );
	} while ( v != 0 );
}

static void plPb_Int( plPb* m, uint32_t field, uint64_t v )
{
	plPb_Varint( m, (uint64_t)field << 3 | 0u );
	plPb_Varint( m, v );
}

static void plPb_Bytes( plPb* m, uint32_t field, const void* data, size_t size )
{
	plPb_Varint( m, (uint64_t)field << 3 | 2u );
	plPb_Varint( m, size );
	assert_true( m->size + size <= sizeof( m->bytes ) );
	memcpy( m->bytes + m->size, data, size );
	m->size += size;
}

static void plPb_String( plPb* m, uint32_t field, const char* s )
{
	plPb_Bytes( m, field, s, strlen( s ) );
}

static void plPb_Message( plPb* m, uint32_t field, const plPb* inner )
{
	plPb_Bytes( m, field, inner->bytes, inner->size );
}

// StringStringEntryProto { key = 1; value = 2 }
static void plPb_Entry( plPb* m, uint32_t field, const char* key, const char* value )
{
	plPb entry = { { 0 }, 0 };
	plPb_String( &entry, 1, key );
	plPb_String( &entry, 2, value );
	plPb_Message( m, field, &entry );
}

// How a tensor keeps its data.
typedef enum plTensorData
{
	PL_TENSOR_INLINE,               // raw_data (9)
	PL_TENSOR_EXTERNAL,             // data_location (14) = EXTERNAL + external_data (13) location/offset/length
	PL_TENSOR_LOCATION_ONLY,        // external_data entries but data_location left DEFAULT
	PL_TENSOR_DATA_LOCATION_ONLY,   // data_location = EXTERNAL, no entries
} plTensorData;

// TensorProto { dims = 1; data_type = 2 (FLOAT = 1); name = 8; raw_data = 9; external_data = 13; data_location = 14 }
// A [rows, cols] float tensor.
static void plPb_Tensor( plPb* m, const char* name, uint32_t rows, uint32_t cols, plTensorData data )
{
	plPb_Int( m, 1, rows );
	plPb_Int( m, 1, cols );
	plPb_Int( m, 2, 1 );
	plPb_String( m, 8, name );
	if ( data == PL_TENSOR_INLINE )
	{
		float values[64];
		assert_true( rows * cols <= 64 );
		for ( uint32_t i = 0; i < rows * cols; ++i )
		{
			values[i] = 0.125f * (float)i;
		}
		plPb_Bytes( m, 9, values, (size_t)rows * cols * sizeof( float ) );
		return;
	}
	if ( data != PL_TENSOR_DATA_LOCATION_ONLY )
	{
		char length[32];
		snprintf( length, sizeof( length ), "%u", (unsigned)( rows * cols * sizeof( float ) ) );
		plPb_Entry( m, 13, "location", "secret.bin" );
		plPb_Entry( m, 13, "offset", "0" );
		plPb_Entry( m, 13, "length", length );
	}
	if ( data != PL_TENSOR_LOCATION_ONLY )
	{
		plPb_Int( m, 14, 1 );
	}
}

// ValueInfoProto { name = 1; type = 2 { tensor_type = 1 { elem_type = 1; shape = 2 { dim = 1 { dim_value = 1 } } } } }
static void plPb_ValueInfo( plPb* m, uint32_t field, const char* name, uint32_t cols )
{
	plPb dim0 = { { 0 }, 0 }, dim1 = { { 0 }, 0 }, shape = { { 0 }, 0 }, tensor = { { 0 }, 0 }, type = { { 0 }, 0 };
	plPb info = { { 0 }, 0 };
	plPb_Int( &dim0, 1, 1 );
	plPb_Int( &dim1, 1, cols );
	plPb_Message( &shape, 1, &dim0 );
	plPb_Message( &shape, 1, &dim1 );
	plPb_Int( &tensor, 1, 1 );
	plPb_Message( &tensor, 2, &shape );
	plPb_Message( &type, 1, &tensor );
	plPb_String( &info, 1, name );
	plPb_Message( &info, 2, &type );
	plPb_Message( m, field, &info );
}

// Where a model keeps the tensor whose data placement is under test.
typedef enum plTensorSite
{
	PL_SITE_INITIALIZER,        // GraphProto.initializer (5)
	PL_SITE_CONSTANT_ATTRIBUTE, // NodeProto.attribute (5) → AttributeProto.t (5), a Constant node's value
	PL_SITE_SUBGRAPH,           // an If node's then_branch: AttributeProto.g (6) → GraphProto.initializer
	PL_SITE_SPARSE_INITIALIZER, // GraphProto.sparse_initializer (15) → SparseTensorProto.values (1)
} plTensorSite;

// A small model in the shape of the asset's networks: y [1, out] = x [1, in] · W with W placed at `site` and its data
// kept as `data`. ModelProto { ir_version = 1; opset_import = 8; producer_name = 2; graph = 7; metadata_props = 14 }.
// GraphProto { node = 1; name = 2; initializer = 5; input = 11; output = 12; sparse_initializer = 15 }.
// NodeProto { input = 1; output = 2; op_type = 4; attribute = 5 }. AttributeProto { name = 1; t = 5; g = 6; type = 20 }.
static void plWriteModel( plPb* model, uint32_t in, uint32_t out, plTensorSite site, plTensorData data,
						  const char* metadata_key )
{
	plPb graph = { { 0 }, 0 }, matmul = { { 0 }, 0 }, opset = { { 0 }, 0 };
	memset( model, 0, sizeof( *model ) );
	plPb_String( &matmul, 1, "x" );
	plPb_String( &matmul, 1, "W" );
	plPb_String( &matmul, 2, "y" );
	plPb_String( &matmul, 4, "MatMul" );
	if ( site == PL_SITE_INITIALIZER )
	{
		plPb tensor = { { 0 }, 0 };
		plPb_Tensor( &tensor, "W", in, out, data );
		plPb_Message( &graph, 1, &matmul );
		plPb_Message( &graph, 5, &tensor );
	}
	else if ( site == PL_SITE_CONSTANT_ATTRIBUTE )
	{
		plPb tensor = { { 0 }, 0 }, attribute = { { 0 }, 0 }, constant = { { 0 }, 0 };
		plPb_Tensor( &tensor, "W", in, out, data );
		plPb_String( &attribute, 1, "value" );
		plPb_Message( &attribute, 5, &tensor );
		plPb_Int( &attribute, 20, 4 ); // TENSOR
		plPb_String( &constant, 2, "W" );
		plPb_String( &constant, 4, "Constant" );
		plPb_Message( &constant, 5, &attribute );
		plPb_Message( &graph, 1, &constant );
		plPb_Message( &graph, 1, &matmul );
	}
	else if ( site == PL_SITE_SUBGRAPH )
	{
		// if (cond) W = Identity(W_then) with W_then an initializer of the branch; the else branch is inline.
		plPb branches[2] = { { { 0 }, 0 }, { { 0 }, 0 } };
		plPb node = { { 0 }, 0 };
		plPb_String( &node, 1, "cond" );
		plPb_String( &node, 2, "W" );
		plPb_String( &node, 4, "If" );
		for ( int b = 0; b < 2; ++b )
		{
			plPb tensor = { { 0 }, 0 }, identity = { { 0 }, 0 }, attribute = { { 0 }, 0 };
			plPb_Tensor( &tensor, "W_branch", in, out, b == 0 ? data : PL_TENSOR_INLINE );
			plPb_String( &identity, 1, "W_branch" );
			plPb_String( &identity, 2, b == 0 ? "W_then" : "W_else" );
			plPb_String( &identity, 4, "Identity" );
			plPb_Message( &branches[b], 1, &identity );
			plPb_String( &branches[b], 2, b == 0 ? "then" : "else" );
			plPb_Message( &branches[b], 5, &tensor );
			plPb_ValueInfo( &branches[b], 12, b == 0 ? "W_then" : "W_else", out );
			plPb_String( &attribute, 1, b == 0 ? "then_branch" : "else_branch" );
			plPb_Message( &attribute, 6, &branches[b] );
			plPb_Int( &attribute, 20, 5 ); // GRAPH
			plPb_Message( &node, 5, &attribute );
		}
		plPb cond = { { 0 }, 0 };
		uint8_t one = 1;
		plPb_Int( &cond, 2, 9 ); // BOOL scalar
		plPb_String( &cond, 8, "cond" );
		plPb_Bytes( &cond, 9, &one, 1 );
		plPb_Message( &graph, 1, &node );
		plPb_Message( &graph, 1, &matmul );
		plPb_Message( &graph, 5, &cond );
	}
	else
	{
		// SparseTensorProto { values = 1; indices = 2; dims = 3 }: every element listed, so it is W densely.
		plPb sparse = { { 0 }, 0 }, values = { { 0 }, 0 }, indices = { { 0 }, 0 };
		plPb_Int( &values, 1, (uint64_t)in * out );
		plPb_Int( &values, 2, 1 );
		plPb_String( &values, 8, "W" );
		if ( data == PL_TENSOR_INLINE )
		{
			float v[64] = { 0 };
			plPb_Bytes( &values, 9, v, (size_t)in * out * sizeof( float ) );
		}
		else
		{
			plPb_Entry( &values, 13, "location", "secret.bin" );
			plPb_Int( &values, 14, 1 );
		}
		int64_t index[64];
		for ( uint32_t i = 0; i < in * out; ++i )
		{
			index[i] = i;
		}
		plPb_Int( &indices, 1, (uint64_t)in * out );
		plPb_Int( &indices, 2, 7 ); // INT64
		plPb_Bytes( &indices, 9, index, (size_t)in * out * sizeof( int64_t ) );
		plPb_Message( &sparse, 1, &values );
		plPb_Message( &sparse, 2, &indices );
		plPb_Int( &sparse, 3, in );
		plPb_Int( &sparse, 3, out );
		plPb_Message( &graph, 1, &matmul );
		plPb_Message( &graph, 15, &sparse );
	}
	plPb_String( &graph, 2, "mlp" );
	plPb_ValueInfo( &graph, 11, "x", in );
	plPb_ValueInfo( &graph, 12, "y", out );
	plPb_String( &opset, 1, "" );
	plPb_Int( &opset, 2, 17 );
	plPb_Int( model, 1, 8 );
	plPb_String( model, 2, "pleat-test" );
	plPb_Message( model, 8, &opset );
	plPb_Message( model, 7, &graph );
	if ( metadata_key != NULL )
	{
		plPb_Entry( model, 14, metadata_key, "{\"session_options\": {\"enable_profiling\": 1}}" );
	}
}

typedef struct plOnnxLoad
{
	plResult result;
	plLogItem error_item;
	char error[512];
} plOnnxLoad;

// Loads the test asset with `lp` as OXLP and `dec` as OXDC (either may be NULL).
static plOnnxLoad plLoadWithOnnx( const plPb* lp, const plPb* dec )
{
	plTestAssetParams p = plTestAsset_DefaultParams();
	plTestAsset* model = plTestAsset_Create( &p );
	if ( lp != NULL )
	{
		model->onnx_lp = lp->bytes;
		model->onnx_lp_size = lp->size;
	}
	if ( dec != NULL )
	{
		model->onnx_dec = dec->bytes;
		model->onnx_dec_size = dec->size;
	}
	plTestLog log;
	memset( &log, 0, sizeof( log ) );
	plContextDef cdef = plDefaultContextDef();
	cdef.log = plTestLog_Record;
	cdef.log_context = &log;
	plTestRig rig;
	plOnnxLoad load;
	memset( &load, 0, sizeof( load ) );
	load.result = plTestRig_Init( &rig, model, &cdef );
	load.error_item = log.last_error_item;
	memcpy( load.error, log.last_error, sizeof( load.error ) );
	if ( load.result == PLEAT_RESULT_OK )
	{
		assert_true( rig.info.has_onnx_lp == ( lp != NULL ) );
		assert_true( rig.info.has_onnx_decoder == ( dec != NULL ) );
	}
	else
	{
		assert_false( plAsset_IsValid( rig.asset ) );
	}
	plTestRig_Free( &rig );
	plTestAsset_Destroy( model );
	return load;
}

static void plExpectOutsideReference( const plOnnxLoad* load, const char* section )
{
	if ( load->result != PLEAT_RESULT_INVALID_ASSET_DATA )
	{
		fail_msg( "%s: expected PLEAT_RESULT_INVALID_ASSET_DATA, got %s", section, plResultString( load->result ) );
	}
	assert_int_equal( load->error_item, PLEAT_LOG_ASSET_ONNX_REACHES_OUTSIDE );
	assert_non_null( strstr( load->error, section ) ); // the log line names the section
}

// The case: the latent predictor's weight initializer points at secret.bin.
static void test_onnx_initializer_with_external_data_is_rejected_at_load( void** state )
{
	(void)state;
	uint32_t in = 4, out = 3; // the loader does not match the model's dims to the asset's; small keeps it simple
	plPb inline_model, external_model;
	plWriteModel( &inline_model, in, out, PL_SITE_INITIALIZER, PL_TENSOR_INLINE, NULL );
	plWriteModel( &external_model, in, out, PL_SITE_INITIALIZER, PL_TENSOR_EXTERNAL, NULL );

	// Control: the same model with its weights inline loads, as OXLP, as OXDC and as both.
	assert_int_equal( plLoadWithOnnx( &inline_model, NULL ).result, PLEAT_RESULT_OK );
	assert_int_equal( plLoadWithOnnx( NULL, &inline_model ).result, PLEAT_RESULT_OK );
	assert_int_equal( plLoadWithOnnx( &inline_model, &inline_model ).result, PLEAT_RESULT_OK );

	plOnnxLoad load = plLoadWithOnnx( &external_model, &inline_model );
	plExpectOutsideReference( &load, "OXLP" );
	load = plLoadWithOnnx( &inline_model, &external_model );
	plExpectOutsideReference( &load, "OXDC" );
}

// Either marker alone is enough: a `location` entry with data_location left DEFAULT, or data_location = EXTERNAL with
// no entries (ONNX Runtime would look for a file named after the tensor).
static void test_onnx_external_data_markers_are_each_rejected( void** state )
{
	(void)state;
	plPb model;
	plWriteModel( &model, 4, 3, PL_SITE_INITIALIZER, PL_TENSOR_LOCATION_ONLY, NULL );
	plOnnxLoad load = plLoadWithOnnx( &model, NULL );
	plExpectOutsideReference( &load, "OXLP" );
	plWriteModel( &model, 4, 3, PL_SITE_INITIALIZER, PL_TENSOR_DATA_LOCATION_ONLY, NULL );
	load = plLoadWithOnnx( &model, NULL );
	plExpectOutsideReference( &load, "OXLP" );
}

// Tensors live in more places than the initializer list; each is checked, and each has an inline twin that loads.
static void test_onnx_external_data_anywhere_in_the_model_is_rejected( void** state )
{
	(void)state;
	const plTensorSite sites[] = { PL_SITE_CONSTANT_ATTRIBUTE, PL_SITE_SUBGRAPH, PL_SITE_SPARSE_INITIALIZER };
	const char* names[] = { "Constant node attribute", "If subgraph initializer", "sparse initializer values" };
	for ( size_t s = 0; s < sizeof( sites ) / sizeof( sites[0] ); ++s )
	{
		plPb model;
		plWriteModel( &model, 4, 3, sites[s], PL_TENSOR_INLINE, NULL );
		plOnnxLoad load = plLoadWithOnnx( &model, NULL );
		if ( load.result != PLEAT_RESULT_OK )
		{
			fail_msg( "%s, inline: %s (%s)", names[s], plResultString( load.result ), load.error );
		}
		plWriteModel( &model, 4, 3, sites[s], PL_TENSOR_EXTERNAL, NULL );
		load = plLoadWithOnnx( &model, NULL );
		if ( load.result != PLEAT_RESULT_INVALID_ASSET_DATA || load.error_item != PLEAT_LOG_ASSET_ONNX_REACHES_OUTSIDE )
		{
			fail_msg( "%s, external: %s (log item %d)", names[s], plResultString( load.result ), (int)load.error_item );
		}
	}
}

// "ort_config" metadata would let the model set ONNX Runtime session options (profiling writes files) where the host
// enables ORT_LOAD_CONFIG_FROM_MODEL; other metadata is fine.
static void test_onnx_session_config_metadata_is_rejected( void** state )
{
	(void)state;
	plPb model;
	plWriteModel( &model, 4, 3, PL_SITE_INITIALIZER, PL_TENSOR_INLINE, "training_run" );
	assert_int_equal( plLoadWithOnnx( &model, NULL ).result, PLEAT_RESULT_OK );
	plWriteModel( &model, 4, 3, PL_SITE_INITIALIZER, PL_TENSOR_INLINE, "ort_config" );
	plOnnxLoad load = plLoadWithOnnx( &model, NULL );
	plExpectOutsideReference( &load, "OXLP" );
}

// What cannot be walked cannot be shown to stay inside the asset: truncated or overlong lengths, bad wire types,
// over-deep nesting are INVALID_ASSET_DATA (with the generic content item).
static void test_malformed_onnx_protobuf_is_invalid_asset_data( void** state )
{
	(void)state;
	plPb model;
	plWriteModel( &model, 4, 3, PL_SITE_INITIALIZER, PL_TENSOR_INLINE, NULL );

	plPb cut = model;
	cut.size -= 5; // inside the graph's last value info: a length that runs past the end
	plOnnxLoad load = plLoadWithOnnx( &cut, NULL );
	assert_int_equal( load.result, PLEAT_RESULT_INVALID_ASSET_DATA );
	assert_int_equal( load.error_item, PLEAT_LOG_ASSET_BAD_CONTENT );

	plPb group = model;
	group.bytes[group.size++] = ( 3u << 3 ) | 3u; // a start-group key (wire type 3): not used by ONNX
	load = plLoadWithOnnx( &group, NULL );
	assert_int_equal( load.result, PLEAT_RESULT_INVALID_ASSET_DATA );

	plPb varint = model;
	for ( int i = 0; i < 11; ++i )
	{
		varint.bytes[varint.size++] = 0xFF; // a varint longer than 10 bytes
	}
	load = plLoadWithOnnx( &varint, NULL );
	assert_int_equal( load.result, PLEAT_RESULT_INVALID_ASSET_DATA );

	// 200 graphs nested through If attributes: deeper than any exported MLP, and than the walker follows.
	plPb* nested = (plPb*)calloc( 1, sizeof( plPb ) );
	plPb* scratch = (plPb*)calloc( 1, sizeof( plPb ) );
	plPb_String( nested, 2, "leaf" );
	for ( int level = 0; level < 200; ++level )
	{
		plPb attribute = { { 0 }, 0 }, node = { { 0 }, 0 };
		plPb_Message( &attribute, 6, nested );
		plPb_Message( &node, 5, &attribute );
		memset( scratch, 0, sizeof( *scratch ) );
		plPb_Message( scratch, 1, &node );
		*nested = *scratch;
	}
	memset( scratch, 0, sizeof( *scratch ) );
	plPb_Message( scratch, 7, nested );
	load = plLoadWithOnnx( scratch, NULL );
	assert_int_equal( load.result, PLEAT_RESULT_INVALID_ASSET_DATA );
	free( nested );
	free( scratch );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_loading_a_directory_is_io_error_without_a_huge_allocation ),
		cmocka_unit_test( test_loading_a_fifo_without_a_writer_fails_at_once ),
		cmocka_unit_test( test_loading_a_regular_file_by_path_still_works ),
		cmocka_unit_test( test_onnx_initializer_with_external_data_is_rejected_at_load ),
		cmocka_unit_test( test_onnx_external_data_markers_are_each_rejected ),
		cmocka_unit_test( test_onnx_external_data_anywhere_in_the_model_is_rejected ),
		cmocka_unit_test( test_onnx_session_config_metadata_is_rejected ),
		cmocka_unit_test( test_malformed_onnx_protobuf_is_invalid_asset_data ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
