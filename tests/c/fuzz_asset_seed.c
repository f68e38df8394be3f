// Writes the seed corpus for fuzz_asset (scripts/fuzz.sh): small valid assets from the C test asset builder — fp32,
// fp16, with META and SiLU — so libFuzzer starts from inputs that pass the structure and checksum checks.
#include <stdio.h>
#include <string.h>

#include "test_asset_builder.h"

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
	char path[1024];
	snprintf( path, sizeof( path ), "%s/%s", dir, name );
	FILE* file = bytes != NULL ? fopen( path, "wb" ) : NULL;
	int failed = file == NULL || fwrite( bytes, 1, size, file ) != size;
	if ( file != NULL )
	{
		fclose( file );
	}
	plTestAsset_FreeBytes( bytes );
	plTestAsset_Destroy( model );
	return failed;
}

int main( int argc, char** argv )
{
	if ( argc != 2 )
	{
		fprintf( stderr, "usage: fuzz_asset_seed CORPUS_DIR\n" );
		return 2;
	}
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.grid_x = 4;
	p.grid_y = 3;
	int failed = plWriteSeed( argv[1], "small_fp32.pleat", &p, NULL );
	p.fp16 = 1;
	p.activation = 2;
	failed |= plWriteSeed( argv[1], "small_fp16_silu_meta.pleat", &p, "{\"seed\": true}" );
	return failed;
}
