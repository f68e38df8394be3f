// libFuzzer target for the asset loader (built with -DPLEAT_FUZZ=ON and CC=clang): the bytes are copied into a
// 64-byte aligned block and parsed with the checksum both checked and skipped, so mutations reach the structure and
// content checks. Any crash, out-of-bounds read (ASan) or undefined behaviour (UBSan) is a bug.
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "asset.h"

int LLVMFuzzerTestOneInput( const uint8_t* data, size_t size );

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
	(void)plAssetData_Parse( block, size, 1, &asset );
	free( block );
	return 0;
}
