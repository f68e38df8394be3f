// libFuzzer target for the asset loader (built with -DPLEAT_FUZZ=ON and CC=clang; scripts/fuzz.sh): the bytes are
// copied into a 64-byte aligned block and parsed with the checksum both checked and skipped, so mutations reach the
// structure and content checks. An input the loader accepts then goes through the runtime — loaded in place through
// the public API, an instance created and stepped twice — because "validated" must mean "safe to run": every index,
// count and size the runtime trusts was checked by the loader. Any crash, out-of-bounds access (ASan) or undefined
// behaviour (UBSan) is a bug.
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "asset.h"
#include "pleat/pleat.h"

int LLVMFuzzerTestOneInput( const uint8_t* data, size_t size );

static void plRunAcceptedAsset( const uint8_t* block, size_t size )
{
	plContextDef cdef = plDefaultContextDef();
	plContext context;
	if ( plCreateContext( &cdef, &context ) != PLEAT_RESULT_OK )
	{
		return;
	}
	plAssetDef adef = plDefaultAssetDef();
	adef.data = block;
	adef.size = size;
	adef.flags = PLEAT_ASSET_FLAG_USE_IN_PLACE | PLEAT_ASSET_FLAG_SKIP_CHECKSUM;
	plAsset asset;
	plInstance instance;
	plAssetInfo info;
	plInstanceDef idef = plDefaultInstanceDef();
	if ( plLoadAsset( context, &adef, &asset ) == PLEAT_RESULT_OK && plAsset_GetInfo( asset, &info ) == PLEAT_RESULT_OK &&
		 ( idef.asset = asset, plCreateInstance( context, &idef, &instance ) >= 0 ) )
	{
		float rotations[PLEAT_MAX_JOINTS * 4];
		for ( uint32_t j = 0; j < PLEAT_MAX_JOINTS; ++j )
		{
			rotations[j * 4 + 0] = 0.0f;
			rotations[j * 4 + 1] = j % 2 ? 0.38268343f : 0.0f; // 45° about Y on every other joint
			rotations[j * 4 + 2] = 0.0f;
			rotations[j * 4 + 3] = j % 2 ? 0.92387953f : 1.0f;
		}
		plFrameInput in;
		memset( &in, 0, sizeof( in ) );
		in.joint_rotations = rotations;
		in.joint_count = info.joint_count;
		in.root_rotation.w = 1.0f;
		in.dt_s = 1.0f / 30.0f;
		for ( int step = 0; step < 2; ++step )
		{
			in.root_translation.x = 0.05f * (float)step;
			(void)plInstance_Step( instance, &in, NULL );
		}
	}
	plDestroyContext( context ); // destroys the instance and the asset too
}

int LLVMFuzzerTestOneInput( const uint8_t* data, size_t size )
{
	uint8_t* block = (uint8_t*)aligned_alloc( 64, ( size + 64 ) & ~(size_t)63 );
	if ( block == NULL )
	{
		return 0;
	}
	if ( size > 0 )
	{
		memcpy( block, data, size );
	}
	plAssetData asset;
	(void)plAssetData_Parse( block, size, 0, &asset );
	if ( plAssetData_Parse( block, size, 1, &asset ) == PLEAT_RESULT_OK )
	{
		plRunAcceptedAsset( block, size );
	}
	free( block );
	return 0;
}
