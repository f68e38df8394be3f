// The asset object (pleat.h, ASSETS; docs/asset-format.md): plLoadAsset reads the file or the buffer, has it parsed
// (asset_format.c: the container; asset_validate.c: the sections and what they mean) and the kernels' tables derived
// (asset_derive.c), and logs a rejection with the section it names; then lookup, destroy and the getters.
#if !defined( _WIN32 ) && !defined( _POSIX_C_SOURCE )
#define _POSIX_C_SOURCE 200809L // stat, open, fstat, fcntl, fdopen (plOpenRegularFile)
#endif
#include "asset.h"

#include "asset_derive.h"
#include "core/core.h"

#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#if !defined( _WIN32 )
#include <fcntl.h>
#include <unistd.h>
#endif

// ---- public API ----

plAssetDef plDefaultAssetDef( void )
{
	plAssetDef def = { .internal_cookie = PLEAT_DEF_COOKIE };
	return def;
}

#if !defined( _WIN32 )
// What a path names when it is not a regular file, for the log.
static const char* plFileKind( mode_t mode )
{
	return S_ISDIR( mode ) ? "a directory" : S_ISFIFO( mode ) ? "a FIFO" : S_ISSOCK( mode ) ? "a socket" :
		   S_ISCHR( mode ) || S_ISBLK( mode ) ? "a device" : "not a regular file";
}
#endif

// Opens an asset file for reading, and its size, only if it is a regular file; IO_ERROR for anything else, with the
// reason in detail. Only a regular file's size is something to allocate for (fopen succeeds on a directory on POSIX
// systems and fseek/ftell then report LONG_MAX, which once became a 2^63-byte request), and only a regular file can be
// opened without waiting: open() on a FIFO blocks until a writer comes, for ever if none does. So the path is checked
// with stat before anything is opened, and opened with O_NONBLOCK and checked again with fstat, in case something
// else took the path in between.
static plResult plOpenRegularFile( const char* path, FILE** out_file, uint64_t* out_size, char* detail,
								   size_t detail_size )
{
#if defined( _WIN32 )
	FILE* file = fopen( path, "rb" );
	if ( file == NULL )
	{
		snprintf( detail, detail_size, "cannot be opened" );
		return PLEAT_RESULT_IO_ERROR;
	}
	struct _stat64 info;
	if ( _fstat64( _fileno( file ), &info ) != 0 || ( info.st_mode & _S_IFMT ) != _S_IFREG || info.st_size < 0 )
	{
		snprintf( detail, detail_size, "not a regular file" );
		fclose( file );
		return PLEAT_RESULT_IO_ERROR;
	}
#else
	struct stat info;
	if ( stat( path, &info ) != 0 )
	{
		snprintf( detail, detail_size, "cannot be opened (no such file, or no permission)" );
		return PLEAT_RESULT_IO_ERROR;
	}
	if ( !S_ISREG( info.st_mode ) )
	{
		snprintf( detail, detail_size, "not a regular file (%s)", plFileKind( info.st_mode ) );
		return PLEAT_RESULT_IO_ERROR;
	}
	int fd = open( path, O_RDONLY | O_NONBLOCK | O_CLOEXEC );
	if ( fd < 0 )
	{
		snprintf( detail, detail_size, "cannot be opened" );
		return PLEAT_RESULT_IO_ERROR;
	}
	FILE* file = NULL;
	int flags = fcntl( fd, F_GETFL );
	if ( fstat( fd, &info ) != 0 || info.st_size < 0 )
	{
		snprintf( detail, detail_size, "cannot be read" );
	}
	else if ( !S_ISREG( info.st_mode ) )
	{
		snprintf( detail, detail_size, "not a regular file (%s)", plFileKind( info.st_mode ) );
	}
	// Reads of a regular file never wait anyway; the flag goes so that stdio sees an ordinary descriptor.
	else if ( flags == -1 || fcntl( fd, F_SETFL, flags & ~O_NONBLOCK ) == -1 ||
			  ( file = fdopen( fd, "rb" ) ) == NULL )
	{
		snprintf( detail, detail_size, "cannot be opened" );
	}
	if ( file == NULL )
	{
		close( fd );
		return PLEAT_RESULT_IO_ERROR;
	}
#endif
	*out_file = file;
	*out_size = (uint64_t)info.st_size;
	return PLEAT_RESULT_OK;
}

// Reads a whole asset file into a 64-byte aligned block; detail (for the log) says why it could not.
static plResult plReadFile( plContextData* ctx, const char* path, void** out_block, size_t* out_size, char* detail,
							size_t detail_size )
{
	FILE* file = NULL;
	uint64_t length = 0;
	plResult r = plOpenRegularFile( path, &file, &length, detail, detail_size );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	if ( length == 0 )
	{
		r = PLEAT_RESULT_TRUNCATED;
	}
	else if ( (uint64_t)(size_t)length != length )
	{
		r = PLEAT_RESULT_OUT_OF_MEMORY; // a 32-bit process cannot hold it
	}
	void* block = NULL;
	if ( r == PLEAT_RESULT_OK )
	{
		block = plAlloc( &ctx->allocator, (size_t)length, 64 );
		if ( block == NULL )
		{
			r = PLEAT_RESULT_OUT_OF_MEMORY;
		}
		else if ( fread( block, 1, (size_t)length, file ) != (size_t)length )
		{
			r = PLEAT_RESULT_IO_ERROR; // shorter than it was a moment ago, or a read error
			snprintf( detail, detail_size, "read failed or the file shrank" );
		}
	}
	fclose( file );
	if ( r != PLEAT_RESULT_OK )
	{
		plFree( &ctx->allocator, block, block != NULL ? (size_t)length : 0 );
		return r;
	}
	*out_block = block;
	*out_size = (size_t)length;
	return PLEAT_RESULT_OK;
}

static plLogItem plLogItemForLoadResult( plResult r )
{
	switch ( r )
	{
		case PLEAT_RESULT_IO_ERROR:
			return PLEAT_LOG_ASSET_IO_ERROR;
		case PLEAT_RESULT_CHECKSUM_MISMATCH:
			return PLEAT_LOG_ASSET_CHECKSUM_MISMATCH;
		case PLEAT_RESULT_MALFORMED_ASSET:
			return PLEAT_LOG_ASSET_BAD_SECTION_TABLE;
		case PLEAT_RESULT_INVALID_ASSET_DATA:
			return PLEAT_LOG_ASSET_BAD_CONTENT;
		case PLEAT_RESULT_OUT_OF_MEMORY:
			return PLEAT_LOG_OUT_OF_MEMORY;
		default:
			return PLEAT_LOG_ASSET_BAD_HEADER;
	}
}

// The asset table's destroy callback (plDestroyObjectFn), also what plDestroyAsset frees with.
static void plAssetData_Destroy( plContextData* ctx, void* object )
{
	plAssetData* asset = (plAssetData*)object;
	plFree( &ctx->allocator, asset->derived_block, asset->derived_size );
	plFree( &ctx->allocator, asset->owned_block, asset->owned_size );
	plFree( &ctx->allocator, asset, sizeof( plAssetData ) );
}

plResult plLoadAsset( plContext context, const plAssetDef* def, plAsset* out_asset )
{
	plContextData* ctx;
	plResult r = plBeginCreate( context, def, out_asset, sizeof( *out_asset ), &ctx );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	if ( def->internal_cookie != PLEAT_DEF_COOKIE || ( def->path == NULL ) == ( def->data == NULL ) ||
		 ( def->data != NULL && def->size == 0 ) ||
		 ( def->flags & ~( PLEAT_ASSET_FLAG_USE_IN_PLACE | PLEAT_ASSET_FLAG_SKIP_CHECKSUM ) ) != 0 )
	{
		return PLEAT_RESULT_INVALID_DEF;
	}
	plAssetData* asset = (plAssetData*)plAllocZeroed( &ctx->allocator, sizeof( plAssetData ), 64 );
	if ( asset == NULL )
	{
		return PLEAT_RESULT_OUT_OF_MEMORY;
	}
	void* owned = NULL;
	size_t owned_size = 0;
	const uint8_t* block = NULL;
	size_t size = 0;
	if ( def->path != NULL )
	{
		r = plReadFile( ctx, def->path, &owned, &owned_size, asset->rejected_detail, sizeof( asset->rejected_detail ) );
		block = (const uint8_t*)owned;
		size = owned_size;
	}
	else if ( ( def->flags & PLEAT_ASSET_FLAG_USE_IN_PLACE ) != 0 && ( (uintptr_t)def->data & 63u ) == 0 )
	{
		block = (const uint8_t*)def->data;
		size = def->size;
	}
	else
	{
		owned = plAlloc( &ctx->allocator, def->size, 64 );
		if ( owned == NULL )
		{
			r = PLEAT_RESULT_OUT_OF_MEMORY;
		}
		else
		{
			memcpy( owned, def->data, def->size );
			owned_size = def->size;
			block = (const uint8_t*)owned;
			size = def->size;
			if ( ( def->flags & PLEAT_ASSET_FLAG_USE_IN_PLACE ) != 0 )
			{
				plLog( ctx, PLEAT_LOG_LEVEL_WARNING, PLEAT_LOG_ASSET_COPIED, "buffer not 64-byte aligned" );
			}
		}
	}
	if ( r == PLEAT_RESULT_OK )
	{
		r = plAssetData_Parse( block, size, ( def->flags & PLEAT_ASSET_FLAG_SKIP_CHECKSUM ) != 0, asset );
	}
	if ( r == PLEAT_RESULT_OK )
	{
		r = plDeriveKernelData( ctx, asset );
		asset->batch_scratch_floats = plBatchScratchFloats( ctx, asset );
	}
	if ( r == PLEAT_RESULT_OK )
	{
		r = plSlotTable_Insert( ctx, &ctx->assets, asset, plAssetData_Destroy, &out_asset->index1,
								&out_asset->generation );
	}
	if ( r != PLEAT_RESULT_OK )
	{
		plLogItem item = asset->rejected_item != PLEAT_LOG_NONE ? asset->rejected_item : plLogItemForLoadResult( r );
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, item, "%s (%s)%s%s", plResultString( r ),
			   def->path != NULL ? def->path : "memory", asset->rejected_detail[0] != '\0' ? ": " : "",
			   asset->rejected_detail );
		plFree( &ctx->allocator, asset->derived_block, asset->derived_size );
		plFree( &ctx->allocator, owned, owned_size );
		plFree( &ctx->allocator, asset, sizeof( plAssetData ) );
		return r;
	}
	asset->owned_block = owned;
	asset->owned_size = owned_size;
	out_asset->context = ctx->handle;
	plLog( ctx, PLEAT_LOG_LEVEL_INFO, PLEAT_LOG_ASSET_LOADED, "'%s': N=%u F=%u J=%u L=%u D=%u", asset->name,
		   asset->vertex_count, asset->face_count, asset->joint_count, asset->latent_count, asset->blend_count );
	return PLEAT_RESULT_OK;
}

plAssetData* plGetAssetData( plAsset asset )
{
	plContextData* ctx = plGetContext( asset.context ); // the context generation too: its slot may have a new context
	return ctx != NULL ? (plAssetData*)plSlotTable_Get( &ctx->assets, asset.index1, asset.generation ) : NULL;
}

int plAsset_IsValid( plAsset asset )
{
	return plGetAssetData( asset ) != NULL;
}

plResult plDestroyAsset( plAsset handle )
{
	plContextData* ctx = plGetContext( handle.context );
	const plAssetData* asset = plGetAssetData( handle );
	if ( asset != NULL && asset->instance_count != 0 )
	{
		plLog( ctx, PLEAT_LOG_LEVEL_ERROR, PLEAT_LOG_ASSET_IN_USE, "%u instances", asset->instance_count );
		return PLEAT_RESULT_ASSET_IN_USE;
	}
	return asset != NULL ? plSlotTable_Destroy( ctx, &ctx->assets, handle.index1, handle.generation )
						 : PLEAT_RESULT_INVALID_HANDLE;
}

plResult plAsset_GetInfo( plAsset handle, plAssetInfo* out_info )
{
	const plAssetData* a = plGetAssetData( handle );
	plResult r = plCheckArgumentsThenHandle( out_info != NULL, a );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	memset( out_info, 0, sizeof( *out_info ) );
	out_info->vertex_count = a->vertex_count;
	out_info->face_count = a->face_count;
	out_info->joint_count = a->joint_count;
	out_info->input_joint_count = a->input_joint_count;
	out_info->influence_count = a->influence_count;
	out_info->beta_count = a->beta_count;
	out_info->latent_count = a->latent_count;
	out_info->blend_count = a->blend_count;
	out_info->input_count = a->input_count;
	out_info->lp_layer_count = a->lp_layer_count;
	out_info->dec_layer_count = a->dec_layer_count;
	out_info->weights_fp16 = a->weights_fp16;
	out_info->weights_int8 = a->weights_int8;
	out_info->dt_min_s = a->dt_min_s;
	out_info->dt_max_s = a->dt_max_s;
	out_info->beta_min = a->beta_min;
	out_info->beta_max = a->beta_max;
	memcpy( out_info->material_min, a->material_min, sizeof( a->material_min ) );
	memcpy( out_info->material_max, a->material_max, sizeof( a->material_max ) );
	memcpy( out_info->material_default, a->material_default, sizeof( a->material_default ) );
	out_info->train_fps = a->train_fps;
	memcpy( out_info->name, a->name, sizeof( a->name ) );
	out_info->meta_json = a->meta;
	out_info->meta_json_size = a->meta_size;
	out_info->has_onnx_lp = a->onnx_lp != NULL;
	out_info->has_onnx_decoder = a->onnx_dec != NULL;
	out_info->pinned_count = a->pinned_count;
	out_info->has_body_contact = a->body_anchors != NULL;
	return PLEAT_RESULT_OK;
}

plResult plAsset_GetJointName( plAsset handle, uint32_t joint_index, const char** out_name )
{
	const plAssetData* a = plGetAssetData( handle );
	plResult r = plCheckArgumentsThenHandle( out_name != NULL, a );
	if ( r == PLEAT_RESULT_OK && joint_index >= a->joint_count )
	{
		r = PLEAT_RESULT_INVALID_ARGUMENT;
	}
	if ( out_name != NULL )
	{
		*out_name = r == PLEAT_RESULT_OK ? a->joint_names + (size_t)joint_index * PLEAT_JOINT_NAME_SIZE : NULL;
	}
	return r;
}

// The two getters that lend an asset array with its row count: the faces (out_faces) or the template positions
// (out_positions, the other one NULL). Both outputs are required; they are null and 0 unless the call succeeds.
static plResult plLendAssetArray( plAsset handle, const uint32_t** out_faces, const float** out_positions,
								  uint32_t* out_count )
{
	if ( ( out_faces == NULL && out_positions == NULL ) || out_count == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	const plAssetData* a = plGetAssetData( handle );
	if ( out_faces != NULL )
	{
		*out_faces = a != NULL ? a->faces : NULL;
		*out_count = a != NULL ? a->face_count : 0;
	}
	else
	{
		*out_positions = a != NULL ? a->template_positions : NULL;
		*out_count = a != NULL ? a->vertex_count : 0;
	}
	return a != NULL ? PLEAT_RESULT_OK : PLEAT_RESULT_INVALID_HANDLE;
}

plResult plAsset_GetFaces( plAsset handle, const uint32_t** out_faces, uint32_t* out_face_count )
{
	return plLendAssetArray( handle, out_faces, NULL, out_face_count );
}

plResult plAsset_GetTemplatePositions( plAsset handle, const float** out_positions, uint32_t* out_vertex_count )
{
	return plLendAssetArray( handle, NULL, out_positions, out_vertex_count );
}

plResult plAsset_FindJoint( plAsset handle, const char* name, int32_t* out_joint_index )
{
	const plAssetData* a = plGetAssetData( handle );
	plResult r = plCheckArgumentsThenHandle( name != NULL && out_joint_index != NULL, a );
	if ( r != PLEAT_RESULT_INVALID_ARGUMENT )
	{
		*out_joint_index = -1;
	}
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	for ( uint32_t j = 0; j < a->joint_count; ++j )
	{
		if ( strncmp( a->joint_names + (size_t)j * PLEAT_JOINT_NAME_SIZE, name, PLEAT_JOINT_NAME_SIZE ) == 0 &&
			 strlen( name ) < PLEAT_JOINT_NAME_SIZE )
		{
			*out_joint_index = (int32_t)j;
			return PLEAT_RESULT_OK;
		}
	}
	return PLEAT_RESULT_NOT_FOUND;
}
