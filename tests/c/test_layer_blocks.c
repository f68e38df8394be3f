// Block-structured layers (layer_blocks.c): plFindLayerBlocks finds the blocks of a packed ensemble's layers (and
// none where skipping would not pay), and an MLP whose layers run block by block gives the dense product's bits —
// single job and batched job (with and without the lanes form), every kernel set, fp32 and fp16. The shipped
// t-shirt, an ensemble, is loaded with blocks in its hidden layers.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "asset.h"
#include "jobs_batch.h"
#include "test_common.h"

static uint32_t s_rng = 1717;
static const char* s_assetDir = "assets"; // argv[1]: the repository's assets/

static float plRand( void )
{
	return plTestRandom( &s_rng );
}

// A layer [out][in] whose rows are `parts` equal blocks, block i non-zero only in columns [col[i], col[i + 1]);
// columns outside every block's window (e.g. shared inputs) are non-zero for all rows when shared_from < in.
typedef struct plBlockLayer
{
	plLayer layer;
	float* w;
	uint16_t* w16;
	float* bias;
} plBlockLayer;

static plBlockLayer plBlockLayer_Make( uint32_t in, uint32_t out, uint32_t parts, const uint32_t* col,
									 uint32_t shared_from, int fp16 )
{
	plBlockLayer t;
	size_t count = (size_t)in * out;
	t.w = (float*)calloc( count + out, sizeof( float ) );
	t.w16 = (uint16_t*)calloc( count, sizeof( uint16_t ) );
	t.bias = t.w + count;
	uint32_t rows = out / parts;
	for ( uint32_t r = 0; r < out; ++r )
	{
		uint32_t part = r / rows;
		for ( uint32_t c = 0; c < in; ++c )
		{
			int inside = ( c >= col[part] && c < col[part + 1] ) || c >= shared_from;
			// the zeros outside alternate +0 and −0 (a packed fp16 asset may hold either)
			t.w[(size_t)r * in + c] = inside ? plRand() / sqrtf( (float)in ) : ( ( r + c ) & 1u ? -0.0f : 0.0f );
			t.w16[(size_t)r * in + c] = plFloatToHalf( t.w[(size_t)r * in + c] );
		}
		t.bias[r] = 0.1f * plRand();
	}
	memset( &t.layer, 0, sizeof( t.layer ) );
	t.layer.weight = fp16 ? (const void*)t.w16 : (const void*)t.w;
	t.layer.weight_fp16 = fp16;
	t.layer.bias = t.bias;
	t.layer.in_count = in;
	t.layer.out_count = out;
	return t;
}

static void plBlockLayer_Free( plBlockLayer* t )
{
	free( t->w );
	free( t->w16 );
}

static void test_finds_the_blocks_of_ensemble_layers_and_none_where_they_do_not_pay( void** state )
{
	(void)state;
	for ( int fp16 = 0; fp16 < 2; ++fp16 )
	{
		// Two members side by side (a hidden layer of a packed pair): two blocks, windows as packed.
		const uint32_t pair[3] = { 0, 48, 96 };
		plBlockLayer t = plBlockLayer_Make( 96, 80, 2, pair, UINT32_MAX, fp16 );
		plFindLayerBlocks( &t.layer );
		assert_int_equal( t.layer.block_count, 2 );
		assert_int_equal( t.layer.blocks[0].row_end, 40 );
		assert_int_equal( t.layer.blocks[0].col_begin, 0 );
		assert_int_equal( t.layer.blocks[0].col_end, 48 );
		assert_int_equal( t.layer.blocks[1].row_begin, 40 );
		assert_int_equal( t.layer.blocks[1].col_begin, 48 );
		assert_int_equal( t.layer.blocks[1].col_end, 96 );
		assert_int_equal( plLayerMacs( &t.layer ), 2 * 40 * 48 );
		plBlockLayer_Free( &t );

		// Four members: four blocks (a quarter of the work) rather than two halves (a half).
		const uint32_t four[5] = { 0, 32, 64, 96, 128 };
		t = plBlockLayer_Make( 128, 64, 4, four, UINT32_MAX, fp16 );
		plFindLayerBlocks( &t.layer );
		assert_int_equal( t.layer.block_count, 4 );
		assert_int_equal( plLayerMacs( &t.layer ), 64 * 32 );
		plBlockLayer_Free( &t );

		// Six members: six blocks (a sixth of the work), found although six is not a power of two.
		const uint32_t six[7] = { 0, 32, 64, 96, 128, 160, 192 };
		t = plBlockLayer_Make( 192, 96, 6, six, UINT32_MAX, fp16 );
		plFindLayerBlocks( &t.layer );
		assert_int_equal( t.layer.block_count, 6 );
		assert_int_equal( t.layer.blocks[5].row_begin, 80 );
		assert_int_equal( t.layer.blocks[5].col_begin, 160 );
		assert_int_equal( plLayerMacs( &t.layer ), 96 * 32 );
		plBlockLayer_Free( &t );

		// Windows not on 16-column boundaries are widened to them (and end at in_count): [0, 32) and [16, 40).
		const uint32_t ragged[3] = { 0, 20, 40 };
		t = plBlockLayer_Make( 40, 16, 2, ragged, UINT32_MAX, fp16 );
		plFindLayerBlocks( &t.layer );
		assert_int_equal( t.layer.block_count, 2 );
		assert_int_equal( t.layer.blocks[0].col_end, 32 );
		assert_int_equal( t.layer.blocks[1].col_begin, 16 );
		assert_int_equal( t.layer.blocks[1].col_end, 40 );
		plBlockLayer_Free( &t );

		// A pair's first layer (own latents, then 200 shared input columns): windows overlap too much to pay.
		const uint32_t first[3] = { 0, 16, 32 };
		t = plBlockLayer_Make( 232, 64, 2, first, 32, fp16 );
		plFindLayerBlocks( &t.layer );
		assert_int_equal( t.layer.block_count, 0 );
		assert_int_equal( plLayerMacs( &t.layer ), 232 * 64 );
		plBlockLayer_Free( &t );

		// A dense layer, and one where a single weight breaks the second block's window.
		const uint32_t whole[2] = { 0, 96 };
		t = plBlockLayer_Make( 96, 80, 1, whole, UINT32_MAX, fp16 );
		plFindLayerBlocks( &t.layer );
		assert_int_equal( t.layer.block_count, 0 );
		plBlockLayer_Free( &t );
		t = plBlockLayer_Make( 96, 80, 2, pair, UINT32_MAX, 0 );
		t.w[(size_t)79 * 96 + 0] = 1e-30f;
		plFindLayerBlocks( &t.layer );
		assert_true( t.layer.block_count == 0 || t.layer.blocks[t.layer.block_count - 1].col_begin == 0 );
		plBlockLayer_Free( &t );
	}
}

// The kernel sets: scalar always, AVX2 when built and supported, with AVX-512 batched twins where the CPU has them.
typedef struct plSets
{
	plKernels single[3];
	plBatchKernels batch[3];
	uint32_t count;
} plSets;

static plSets plGetSets( void )
{
	plSets sets;
	memset( &sets, 0, sizeof( sets ) );
	for ( int set = PLEAT_KERNEL_SET_SCALAR; set <= PLEAT_KERNEL_SET_AVX512; ++set )
	{
		plKernels k;
		if ( plChooseKernels( &k, (plKernelSet)set ) != (plKernelSet)set )
		{
			break; // a set this build or CPU lacks (plChooseKernels gave a narrower one)
		}
		sets.single[sets.count] = k;
		sets.batch[sets.count++] = *k.batch;
	}
	return sets;
}

// A packed ensemble's f_dec-like chain: a dense first layer, a block-diagonal hidden layer of six members with ragged
// windows (member widths 20: windows widened to 16-column boundaries, and a scalar tail), a block-diagonal output
// layer of two. The same chain with blocks and with block_count = 0, every kernel set: the same bits.
static void test_blocked_chain_gives_the_dense_bits( void** state )
{
	(void)state;
	enum
	{
		N = 21, // two lane groups of the lanes form, the second partial
		IN = 37,
		HIDDEN = 120,
		OUT = 26
	};
	const uint32_t dense_cols[2] = { 0, IN }, hidden_cols[7] = { 0, 20, 40, 60, 80, 100, 120 },
				   out_cols[3] = { 0, 60, 120 };
	plSets sets = plGetSets();
	for ( int fp16 = 0; fp16 < 2; ++fp16 )
	{
		plBlockLayer t[3] = { plBlockLayer_Make( IN, HIDDEN, 1, dense_cols, UINT32_MAX, fp16 ),
							 plBlockLayer_Make( HIDDEN, HIDDEN, 6, hidden_cols, UINT32_MAX, fp16 ),
							 plBlockLayer_Make( HIDDEN, OUT, 2, out_cols, UINT32_MAX, fp16 ) };
		plLayer dense[3], blocked[3];
		for ( int l = 0; l < 3; ++l )
		{
			dense[l] = t[l].layer;
			blocked[l] = t[l].layer;
			plFindLayerBlocks( &blocked[l] );
		}
		assert_int_equal( blocked[0].block_count, 0 );
		assert_int_equal( blocked[1].block_count, 6 );
		assert_int_equal( blocked[2].block_count, 2 );
		static float xs[N][IN], y_dense[N][OUT], y_blocked[N][OUT], scratch[N][2 * HIDDEN];
		plConstSpan inputs[N];
		plSpan outputs[N], scratches[N];
		for ( uint32_t b = 0; b < N; ++b )
		{
			for ( uint32_t c = 0; c < IN; ++c )
			{
				xs[b][c] = 2.0f * plRand();
			}
			inputs[b] = plMakeConstSpan( xs[b], IN, 4 );
			scratches[b] = plMakeSpan( scratch[b], 2 * HIDDEN, 4 );
		}
		size_t lanes_floats = plMlpBatchLanesFloats( dense, 3, N );
		float* lanes = (float*)aligned_alloc( 64, ( lanes_floats * sizeof( float ) + 63 ) & ~(size_t)63 );
		for ( uint32_t s = 0; s < sets.count; ++s )
		{
			for ( uint32_t b = 0; b < N; ++b )
			{
				plMlpJob one = { dense,
								 3,
								 PLEAT_ACTIVATION_SILU,
								 inputs[b],
								 plMakeSpan( y_dense[b], OUT, 4 ),
								 scratches[b],
								 &sets.single[s],
								 NULL };
				assert_int_equal( plMlpJob_Run( &one ), PLEAT_RESULT_OK );
				one.layers = blocked;
				one.output = plMakeSpan( y_blocked[b], OUT, 4 );
				assert_int_equal( plMlpJob_Run( &one ), PLEAT_RESULT_OK );
				assert_memory_equal( y_dense[b], y_blocked[b], sizeof( y_dense[b] ) );
			}
			for ( int use_lanes = 0; use_lanes < 2; ++use_lanes )
			{
				for ( uint32_t b = 0; b < N; ++b )
				{
					outputs[b] = plMakeSpan( y_blocked[b], OUT, 4 );
				}
				memset( y_blocked, 0, sizeof( y_blocked ) );
				plMlpBatchJob job = { blocked, 3, PLEAT_ACTIVATION_SILU, N,    inputs, outputs, scratches, &sets.batch[s],
									  NULL,    use_lanes ? lanes : NULL, use_lanes ? lanes_floats : 0, NULL, NULL, NULL };
				assert_int_equal( plMlpBatchJob_Run( &job ), PLEAT_RESULT_OK );
				assert_memory_equal( y_dense, y_blocked, sizeof( y_dense ) );
			}
		}
		free( lanes );
		for ( int l = 0; l < 3; ++l )
		{
			plBlockLayer_Free( &t[l] );
		}
	}
}

// The single step's packed copies (plPackLayer): a chain whose block layers have windows of one width (two members of
// 64 in the hidden layer, three of 48 at the output) packs them, the dense first layer and a ragged one do not, and
// the single job gives the same bits with the copies, without them (blocks read in place) and dense, every kernel
// set, fp32 and fp16.
static void test_packed_block_layers_give_the_same_bits( void** state )
{
	(void)state;
	enum
	{
		IN = 37,
		HIDDEN = 128,
		MIDDLE = 144,
		OUT = 27
	};
	const uint32_t dense_cols[2] = { 0, IN }, pair[3] = { 0, 64, 128 }, triple[4] = { 0, 48, 96, 144 },
				   ragged[3] = { 0, 60, 120 };
	plSets sets = plGetSets();
	for ( int fp16 = 0; fp16 < 2; ++fp16 )
	{
		plBlockLayer t[3] = { plBlockLayer_Make( IN, HIDDEN, 1, dense_cols, UINT32_MAX, fp16 ),
							 plBlockLayer_Make( HIDDEN, MIDDLE, 2, pair, UINT32_MAX, fp16 ),
							 plBlockLayer_Make( MIDDLE, OUT, 3, triple, UINT32_MAX, fp16 ) };
		plLayer dense[3], blocked[3], packed[3];
		void* copies[3] = { NULL, NULL, NULL };
		for ( int l = 0; l < 3; ++l )
		{
			dense[l] = t[l].layer;
			plFindLayerBlocks( &t[l].layer );
			blocked[l] = t[l].layer;
			packed[l] = t[l].layer;
			size_t bytes = plPackedLayerBytes( &packed[l] );
			if ( bytes > 0 )
			{
				copies[l] = malloc( bytes );
				plPackLayer( &packed[l], copies[l] );
			}
		}
		assert_null( copies[0] ); // dense: nothing to pack
		assert_non_null( copies[1] );
		assert_non_null( copies[2] );
		assert_int_equal( packed[1].packed_width, 64 );
		assert_int_equal( packed[2].packed_width, 48 );
		plBlockLayer r = plBlockLayer_Make( 120, 80, 2, ragged, UINT32_MAX, fp16 ); // windows 64 and 72 wide
		plFindLayerBlocks( &r.layer );
		assert_int_equal( r.layer.block_count, 2 );
		assert_int_equal( plPackedLayerBytes( &r.layer ), 0 );
		plBlockLayer_Free( &r );
		float x[IN], scratch[2 * MIDDLE], y_dense[OUT], y_blocked[OUT], y_packed[OUT];
		for ( uint32_t s = 0; s < sets.count; ++s )
		{
			for ( int trial = 0; trial < 4; ++trial )
			{
				for ( uint32_t c = 0; c < IN; ++c )
				{
					x[c] = 2.0f * plRand();
				}
				plLayer* chains[3] = { dense, blocked, packed };
				float* outs[3] = { y_dense, y_blocked, y_packed };
				for ( int k = 0; k < 3; ++k )
				{
					plMlpJob job = { chains[k], 3, PLEAT_ACTIVATION_RELU, plMakeConstSpan( x, IN, 4 ),
									 plMakeSpan( outs[k], OUT, 4 ), plMakeSpan( scratch, 2 * MIDDLE, 4 ), &sets.single[s],
									 NULL };
					assert_int_equal( plMlpJob_Run( &job ), PLEAT_RESULT_OK );
				}
				assert_memory_equal( y_dense, y_blocked, sizeof( y_dense ) );
				assert_memory_equal( y_dense, y_packed, sizeof( y_dense ) );
			}
		}
		for ( int l = 0; l < 3; ++l )
		{
			free( copies[l] );
			plBlockLayer_Free( &t[l] );
		}
	}
}

// The shipped t-shirt is the mean of two fits packed as one network (pleat.train.ensemble): its f_LP hidden and output
// layers and its decoder layers load with two blocks each, so a step does about what the two members do.
static void test_shipped_ensemble_loads_with_blocks( void** state )
{
	(void)state;
	char path[1024];
	snprintf( path, sizeof( path ), "%s/tshirt.pleat", s_assetDir );
	FILE* f = fopen( path, "rb" );
	assert_non_null( f );
	fseek( f, 0, SEEK_END );
	size_t size = (size_t)ftell( f );
	fseek( f, 0, SEEK_SET );
	uint8_t* bytes = (uint8_t*)aligned_alloc( 64, ( size + 63 ) & ~(size_t)63 ); // the parser wants 64-byte alignment
	assert_int_equal( fread( bytes, 1, size, f ), size );
	fclose( f );
	plAssetData a;
	memset( &a, 0, sizeof( a ) );
	assert_int_equal( plAssetData_Parse( bytes, size, 0, &a ), PLEAT_RESULT_OK );
	uint64_t dense = 0, blocked = 0;
	uint32_t with_blocks = 0;
	for ( uint32_t i = 0; i < a.lp_layer_count + a.dec_layer_count; ++i )
	{
		const plLayer* l = i < a.lp_layer_count ? &a.lp[i] : &a.dec[i - a.lp_layer_count];
		dense += (uint64_t)l->in_count * l->out_count;
		blocked += plLayerMacs( l );
		with_blocks += l->block_count == 2;
	}
	print_message( "shipped t-shirt: %u of %u layers in two blocks, %.0f%% of the dense multiply-adds\n", with_blocks,
				   a.lp_layer_count + a.dec_layer_count, 100.0 * (double)blocked / (double)dense );
	assert_int_equal( with_blocks, a.lp_layer_count - 1 + a.dec_layer_count ); // all but f_LP's first layer
	assert_true( blocked < dense * 3 / 4 );
	// Loaded through the API, those layers get their packed copies (their windows are the members' widths), in the
	// asset's memory: destroying the asset leaves the context's live bytes where they were.
	plContextDef cdef = plDefaultContextDef();
	plContext context;
	assert_int_equal( plCreateContext( &cdef, &context ), PLEAT_RESULT_OK );
	uint64_t live_before = 0, live_after = 0;
	assert_int_equal( plContext_GetLiveBytes( context, &live_before ), PLEAT_RESULT_OK );
	plAssetDef adef = plDefaultAssetDef();
	adef.data = bytes;
	adef.size = size;
	plAsset asset;
	assert_int_equal( plLoadAsset( context, &adef, &asset ), PLEAT_RESULT_OK );
	const plAssetData* loaded = plGetAssetData( asset );
	assert_non_null( loaded );
	uint32_t packed = 0;
	for ( uint32_t i = 0; i < loaded->lp_layer_count + loaded->dec_layer_count; ++i )
	{
		const plLayer* l = i < loaded->lp_layer_count ? &loaded->lp[i] : &loaded->dec[i - loaded->lp_layer_count];
		packed += l->packed != NULL;
		assert_true( ( l->packed != NULL ) == ( l->block_count == 2 ) );
	}
	assert_int_equal( packed, with_blocks );
	plDestroyAsset( asset );
	assert_int_equal( plContext_GetLiveBytes( context, &live_after ), PLEAT_RESULT_OK );
	assert_int_equal( live_after, live_before );
	plDestroyContext( context );
	free( bytes );
}

// Loading the shipped ensemble with the host allocator failing at the k-th allocation, for every k the load reaches
// (the packed copies are its last): OUT_OF_MEMORY and a null handle, or a loaded asset whose block layers are all
// packed; either way every byte comes back.
static void test_packing_fails_cleanly_without_memory( void** state )
{
	(void)state;
	char path[1024];
	snprintf( path, sizeof( path ), "%s/tshirt.pleat", s_assetDir );
	int loaded = 0;
	for ( int64_t k = 0; k < 16 && !loaded; ++k )
	{
		plCountingHost host;
		plContextDef def = plCountingHost_ContextDef( &host );
		plContext context;
		assert_int_equal( plCreateContext( &def, &context ), PLEAT_RESULT_OK );
		host.fail_after = host.allocations + k; // the context is made; the load's k-th allocation fails
		plAssetDef adef = plDefaultAssetDef();
		adef.path = path;
		plAsset asset;
		plResult r = plLoadAsset( context, &adef, &asset );
		if ( r == PLEAT_RESULT_OK )
		{
			const plAssetData* a = plGetAssetData( asset );
			for ( uint32_t i = 0; i < a->lp_layer_count + a->dec_layer_count; ++i )
			{
				const plLayer* l = i < a->lp_layer_count ? &a->lp[i] : &a->dec[i - a->lp_layer_count];
				assert_true( ( l->packed != NULL ) == ( l->block_count == 2 ) );
			}
			loaded = 1;
			// the asset's record, the file's block and the packed copies at least: all three failed once before
			print_message( "shipped t-shirt: loads once %lld allocations may succeed\n", (long long)k );
			assert_true( k >= 3 );
		}
		else
		{
			assert_int_equal( r, PLEAT_RESULT_OUT_OF_MEMORY );
			assert_false( plAsset_IsValid( asset ) );
		}
		plDestroyContext( context );
		assert_int_equal( host.live_bytes, 0 );
	}
	assert_true( loaded );
}

int main( int argc, char** argv )
{
	if ( argc > 1 )
	{
		s_assetDir = argv[1];
	}
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_finds_the_blocks_of_ensemble_layers_and_none_where_they_do_not_pay ),
		cmocka_unit_test( test_blocked_chain_gives_the_dense_bits ),
		cmocka_unit_test( test_packed_block_layers_give_the_same_bits ),
		cmocka_unit_test( test_shipped_ensemble_loads_with_blocks ),
		cmocka_unit_test( test_packing_fails_cleanly_without_memory ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
