// Writes the seed corpora of the fuzz targets (scripts/fuzz.sh):
//
//     fuzz_asset_seed RAW_DIR [SEMANTIC_DIR]
//
// RAW_DIR (fuzz_asset): small valid assets from the C test asset builder — fp32; fp16 + SiLU + META; no β (no
// JSHP/SHPB rows) with one influence; deeper networks, eight influences and a longer skeleton; all-zero networks — next
// to whatever RAW_DIR already holds (scripts/fuzz.sh first writes the pleat-pack seeds of tests/c/fuzz_seeds.py there:
// PINS, OXLP/OXDC, the SMPL skeleton). SEMANTIC_DIR (fuzz_asset_semantic): every asset of RAW_DIR behind each of a few
// control blocks (fuzz_control.h) that between them turn on every choice of the harness once.
#define _DEFAULT_SOURCE // readdir's d_type
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_control.h"
#include "test_asset_builder.h"

static int plWriteFile( const char* dir, const char* name, const char* suffix, const void* head, size_t head_size,
						const void* bytes, size_t size )
{
	char path[1024];
	snprintf( path, sizeof( path ), "%s/%s%s", dir, name, suffix );
	FILE* file = fopen( path, "wb" );
	if ( file == NULL )
	{
		return 1;
	}
	int failed = ( head_size > 0 && fwrite( head, 1, head_size, file ) != head_size ) ||
				 fwrite( bytes, 1, size, file ) != size;
	return fclose( file ) != 0 || failed;
}

static int plWriteSeed( const char* dir, const char* name, const plTestAssetParams* params, const char* meta )
{
	plTestAsset* model = plTestAsset_Create( params );
	if ( model == NULL )
	{
		return 1;
	}
	model->meta = meta;
	size_t size = 0;
	uint8_t* bytes = plTestAsset_Write( model, &size );
	int failed = bytes == NULL || plWriteFile( dir, name, "", NULL, 0, bytes, size );
	plTestAsset_FreeBytes( bytes );
	plTestAsset_Destroy( model );
	return failed;
}

// A β-less asset without JSHP and SHPB at all (the loader allows that when B = 0): the two table entries get fourccs
// no reader knows, which a 1.x reader skips.
static int plWriteNoShapeSections( const char* dir, const char* name, const plTestAssetParams* params )
{
	plTestAsset* model = plTestAsset_Create( params );
	size_t size = 0;
	uint8_t* bytes = model != NULL ? plTestAsset_Write( model, &size ) : NULL;
	int failed = bytes == NULL;
	if ( !failed )
	{
		size_t jshp = plTestAsset_SectionEntryOffset( bytes, "JSHP" ), shpb = plTestAsset_SectionEntryOffset( bytes, "SHPB" );
		failed = jshp == 0 || shpb == 0;
		if ( !failed )
		{
			memcpy( bytes + jshp, "XSHP", 4 );
			memcpy( bytes + shpb, "XSHB", 4 );
			plTestAsset_FixChecksum( bytes, size );
			failed = plWriteFile( dir, name, "", NULL, 0, bytes, size );
		}
	}
	plTestAsset_FreeBytes( bytes );
	plTestAsset_Destroy( model );
	return failed;
}

// The control blocks: c0 is the plain default path; the others switch on, between them, every flag and mode.
static plFuzzControl plControl( int variant )
{
	plFuzzControl c;
	memset( &c, 0, sizeof( c ) );
	for ( int i = 0; i < 16; ++i )
	{
		c.beta[i] = (int8_t)( ( i * 37 + variant * 11 ) % 160 - 80 ); // ±5: some beyond the usual ±4 clamp
		c.pose[i] = (uint8_t)( 97 + i * 29 + variant * 53 );
	}
	for ( int m = 0; m < 4; ++m )
	{
		c.material[m] = (uint8_t)( 20 + 60 * m + 7 * variant ); // some below the range (clamped)
	}
	c.root[0] = 150;
	c.root[1] = 130;
	c.root[2] = 120;
	c.root[3] = 170;
	c.step_count = 2;
	switch ( variant )
	{
		case 1:
			c.flags = PLEAT_FUZZ_FORCE_SCALAR | PLEAT_FUZZ_REVERSE_RANGES | PLEAT_FUZZ_CHECK_DETERMINISM;
			c.workers = 3; // 4 workers
			c.joint_map_mode = 1;
			c.output_mode = 1;
			c.step_count = 3;
			c.setter_steps = 0x06;
			c.setter_kinds = 0x04; // step 1: material, step 2: shape
			c.beta_count = 3;
			c.flags2 = PLEAT_FUZZ2_INITIAL_SHAPE;
			break;
		case 2:
			c.flags = PLEAT_FUZZ_DEFER_TASKS | PLEAT_FUZZ_CHECK_DETERMINISM | PLEAT_FUZZ_BAD_INPUT_PROBES;
			c.workers = 2;
			c.joint_map_mode = 2;
			c.extra_joints = 3;
			c.output_mode = 2;
			c.input_stride = 2;
			c.network_rate = 3; // 15 Hz
			c.dt = 0x19;        // dt varies per step
			c.step_count = 5;
			c.setter_steps = 0x0C;
			c.setter_kinds = 0xE0; // step 2: rate, step 3: reset
			break;
		case 3:
			c.flags = PLEAT_FUZZ_LOAD_FROM_FILE | PLEAT_FUZZ_ONNXRUNTIME | PLEAT_FUZZ_FORCE_SCALAR;
			c.joint_map_mode = 3;
			c.output_mode = 3;
			c.flags2 = PLEAT_FUZZ2_OFF_UNIT_QUATS | PLEAT_FUZZ2_ZERO_ROOT_ROTATION | PLEAT_FUZZ2_DESTROY_IN_USE;
			c.dt = 3; // below the asset's dt range: clamped
			break;
		case 4:
			c.flags = PLEAT_FUZZ_IN_PLACE | PLEAT_FUZZ_ONNXRUNTIME | PLEAT_FUZZ_CHECK_DETERMINISM;
			c.workers = 1;
			c.output_mode = 4;
			c.step_count = 5;
			c.setter_steps = 0x1F;
			c.setter_kinds = 0x1B; // reset, rate, material, shape
			c.beta_count = 17;     // one more than the asset has for assets with B ≤ 15: rejected
			c.network_rate = 6;
			break;
		case 5:
			c.fail_allocation = 3;
			c.output_mode = 5;
			c.joint_map_mode = 4;
			break;
		default:
			break;
	}
	return c;
}
#define PLEAT_SEED_CONTROL_COUNT 6

static int plWriteSemanticSeeds( const char* raw_dir, const char* semantic_dir )
{
	DIR* dir = opendir( raw_dir );
	if ( dir == NULL )
	{
		return 1;
	}
	int failed = 0;
	struct dirent* entry;
	while ( ( entry = readdir( dir ) ) != NULL )
	{
		if ( entry->d_name[0] == '.' )
		{
			continue;
		}
		char path[1024];
		snprintf( path, sizeof( path ), "%s/%s", raw_dir, entry->d_name );
		FILE* file = fopen( path, "rb" );
		if ( file == NULL )
		{
			failed = 1;
			continue;
		}
		fseek( file, 0, SEEK_END );
		long size = ftell( file );
		fseek( file, 0, SEEK_SET );
		uint8_t* bytes = size > 0 ? (uint8_t*)malloc( (size_t)size ) : NULL;
		if ( bytes == NULL || fread( bytes, 1, (size_t)size, file ) != (size_t)size )
		{
			failed = 1;
		}
		else
		{
			for ( int v = 0; v < PLEAT_SEED_CONTROL_COUNT; ++v )
			{
				plFuzzControl control = plControl( v );
				char suffix[8];
				snprintf( suffix, sizeof( suffix ), ".c%d", v );
				failed |= plWriteFile( semantic_dir, entry->d_name, suffix, &control, sizeof( control ), bytes,
									   (size_t)size );
			}
		}
		free( bytes );
		fclose( file );
	}
	closedir( dir );
	return failed;
}

int main( int argc, char** argv )
{
	if ( argc != 2 && argc != 3 )
	{
		fprintf( stderr, "usage: fuzz_asset_seed RAW_DIR [SEMANTIC_DIR]\n" );
		return 2;
	}
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.grid_x = 4;
	p.grid_y = 3;
	int failed = plWriteSeed( argv[1], "small_fp32.pleat", &p, NULL );
	p.fp16 = 1;
	p.activation = 2;
	failed |= plWriteSeed( argv[1], "small_fp16_silu_meta.pleat", &p, "{\"seed\": true}" );

	plTestAssetParams q = plTestAsset_DefaultParams();
	q.grid_x = 3;
	q.grid_y = 3;
	q.beta_count = 0;
	q.influence_count = 1;
	failed |= plWriteSeed( argv[1], "no_beta_one_influence.pleat", &q, NULL );
	failed |= plWriteNoShapeSections( argv[1], "no_beta_no_shape_sections.pleat", &q );

	plTestAssetParams d = plTestAsset_DefaultParams();
	d.grid_x = 5;
	d.grid_y = 4;
	d.joint_count = 12;
	d.input_joint_count = 8;
	d.influence_count = 8;
	d.beta_count = 16;
	d.lp_hidden[0] = 9;
	d.lp_hidden[1] = 17;
	d.lp_hidden[2] = 8;
	d.dec_hidden[0] = 33;
	d.dec_hidden[1] = 7;
	d.latent_count = 5;
	d.blend_count = 11;
	failed |= plWriteSeed( argv[1], "deep_eight_influences.pleat", &d, NULL );

	plTestAssetParams z = plTestAsset_DefaultParams();
	z.grid_x = 3;
	z.grid_y = 2;
	z.weight_scale = 0.0f;
	failed |= plWriteSeed( argv[1], "zero_networks.pleat", &z, NULL );

	if ( argc == 3 )
	{
		failed |= plWriteSemanticSeeds( argv[1], argv[2] );
	}
	return failed;
}
