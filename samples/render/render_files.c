// Readers for PLBODY01 and PLMOTION (docs/demo.md). Every count is checked against the file size before any array
// pointer is made; arrays are 4-byte aligned by construction of the formats.
#include "render_files.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct Reader
{
	const uint8_t* data;
	size_t size;
	size_t offset;
	const char* path;
	int failed;
} Reader;

static void* readWholeFile( const char* path, size_t* size )
{
	FILE* file = fopen( path, "rb" );
	if ( file == NULL )
	{
		fprintf( stderr, "render: cannot open %s\n", path );
		return NULL;
	}
	void* data = NULL;
	long length = -1;
	if ( fseek( file, 0, SEEK_END ) == 0 && ( length = ftell( file ) ) > 0 && fseek( file, 0, SEEK_SET ) == 0 )
	{
		data = malloc( (size_t)length );
		if ( data != NULL && fread( data, 1, (size_t)length, file ) != (size_t)length )
		{
			free( data );
			data = NULL;
		}
	}
	fclose( file );
	if ( data == NULL )
	{
		fprintf( stderr, "render: cannot read %s\n", path );
	}
	*size = (size_t)length;
	return data;
}

// Returns a pointer to `count` elements of `element_size` bytes, or NULL (and marks the reader failed) if the file
// is too short. The product is checked for overflow first.
static const void* take( Reader* reader, uint64_t count, size_t element_size )
{
	if ( reader->failed )
	{
		return NULL;
	}
	uint64_t bytes = count * element_size;
	if ( element_size != 0 && bytes / element_size != count )
	{
		reader->failed = 1;
		return NULL;
	}
	if ( bytes > reader->size - reader->offset )
	{
		fprintf( stderr, "render: %s is truncated\n", reader->path );
		reader->failed = 1;
		return NULL;
	}
	const void* p = reader->data + reader->offset;
	reader->offset += (size_t)bytes;
	return p;
}

// The next 4 bytes into *out (left as it was if the file is too short).
static void takeWord( Reader* reader, void* out )
{
	const void* p = take( reader, 1, 4 );
	if ( p != NULL )
	{
		memcpy( out, p, 4 );
	}
}

static uint32_t takeU32( Reader* reader )
{
	uint32_t value = 0;
	takeWord( reader, &value );
	return value;
}

static float takeF32( Reader* reader )
{
	float value = 0.0f;
	takeWord( reader, &value );
	return value;
}

static int checkMagic( Reader* reader, const char* magic )
{
	const void* p = take( reader, 8, 1 );
	if ( p == NULL || memcmp( p, magic, 8 ) != 0 )
	{
		fprintf( stderr, "render: %s is not a %.8s file\n", reader->path, magic );
		return -1;
	}
	uint32_t version = takeU32( reader );
	if ( version != 1 )
	{
		fprintf( stderr, "render: %s has version %u, this reader knows 1\n", reader->path, version );
		return -1;
	}
	return 0;
}

// Reads the whole file and checks its magic and version: the block the reader walks (the caller frees it), or NULL
// after saying why on stderr.
static void* openReader( Reader* reader, const char* path, const char* magic )
{
	memset( reader, 0, sizeof( *reader ) );
	reader->path = path;
	void* block = readWholeFile( path, &reader->size );
	reader->data = block;
	if ( block != NULL && checkMagic( reader, magic ) != 0 )
	{
		free( block );
		return NULL;
	}
	return block;
}

static void takeNames( Reader* reader, char names[][RENDER_NAME_BYTES], uint32_t count )
{
	const char* p = take( reader, count, RENDER_NAME_BYTES );
	for ( uint32_t i = 0; p != NULL && i < count; ++i )
	{
		memcpy( names[i], p + (size_t)i * RENDER_NAME_BYTES, RENDER_NAME_BYTES );
		names[i][RENDER_NAME_BYTES - 1] = '\0';
	}
}

static int allFinite( const float* values, size_t count )
{
	for ( size_t i = 0; i < count; ++i )
	{
		if ( !isfinite( values[i] ) )
		{
			return 0;
		}
	}
	return 1;
}

// Says what is wrong with the file (problem NULL: already said), frees the body and returns -1.
static int rejectBody( RenderBody* body, const char* path, const char* problem )
{
	if ( problem != NULL )
	{
		fprintf( stderr, "render: %s %s\n", path, problem );
	}
	renderBody_Free( body );
	return -1;
}

int renderBody_Load( RenderBody* body, const char* path )
{
	memset( body, 0, sizeof( *body ) );
	Reader reader;
	body->block = openReader( &reader, path, "PLBODY01" );
	if ( body->block == NULL )
	{
		return -1;
	}
	body->vertex_count = takeU32( &reader );
	body->face_count = takeU32( &reader );
	body->joint_count = takeU32( &reader );
	body->influence_count = takeU32( &reader );
	body->beta_count = takeU32( &reader );
	if ( body->joint_count == 0 || body->joint_count > RENDER_MAX_JOINTS || body->beta_count > RENDER_MAX_BETAS ||
		 body->influence_count == 0 || body->influence_count > body->joint_count || body->vertex_count == 0 ||
		 body->face_count == 0 )
	{
		return rejectBody( body, path, "has counts out of range" );
	}
	for ( uint32_t b = 0; b < body->beta_count; ++b )
	{
		body->beta[b] = takeF32( &reader );
	}
	takeNames( &reader, body->joint_names, body->joint_count );
	uint64_t v = body->vertex_count, k = body->influence_count;
	body->joints = (float*)take( &reader, (uint64_t)body->joint_count * 3, 4 );
	body->vertices = (float*)take( &reader, v * 3, 4 );
	body->faces = (uint32_t*)take( &reader, (uint64_t)body->face_count * 3, 4 );
	body->skin_indices = (uint32_t*)take( &reader, v * k, 4 );
	body->skin_weights = (float*)take( &reader, v * k, 4 );
	if ( reader.failed )
	{
		return rejectBody( body, path, NULL );
	}
	for ( uint64_t i = 0; i < (uint64_t)body->face_count * 3; ++i )
	{
		if ( body->faces[i] >= body->vertex_count )
		{
			return rejectBody( body, path, "has a face index out of range" );
		}
	}
	for ( uint64_t i = 0; i < v * k; ++i )
	{
		if ( body->skin_indices[i] >= body->joint_count )
		{
			return rejectBody( body, path, "has a skin index out of range" );
		}
	}
	if ( !allFinite( body->vertices, v * 3 ) || !allFinite( body->joints, body->joint_count * 3u ) ||
		 !allFinite( body->skin_weights, v * k ) )
	{
		return rejectBody( body, path, "has non-finite values" );
	}
	return 0;
}

void renderBody_Free( RenderBody* body )
{
	free( body->block );
	memset( body, 0, sizeof( *body ) );
}

int renderMotion_Load( RenderMotion* motion, const char* path )
{
	memset( motion, 0, sizeof( *motion ) );
	Reader reader;
	motion->block = openReader( &reader, path, "PLMOTION" );
	if ( motion->block == NULL )
	{
		return -1;
	}
	motion->frame_count = takeU32( &reader );
	motion->joint_count = takeU32( &reader );
	motion->fps = takeF32( &reader );
	if ( motion->frame_count == 0 || motion->joint_count == 0 || motion->joint_count > RENDER_MAX_JOINTS ||
		 !( motion->fps > 0.0f && motion->fps < 1000.0f ) )
	{
		fprintf( stderr, "render: %s has counts or fps out of range\n", path );
		renderMotion_Free( motion );
		return -1;
	}
	takeNames( &reader, motion->joint_names, motion->joint_count );
	motion->frame_floats = motion->joint_count * 4 + 7;
	motion->frames = take( &reader, (uint64_t)motion->frame_count * motion->frame_floats, 4 );
	if ( reader.failed || !allFinite( motion->frames, (size_t)motion->frame_count * motion->frame_floats ) )
	{
		fprintf( stderr, "render: %s is truncated or has non-finite values\n", path );
		renderMotion_Free( motion );
		return -1;
	}
	return 0;
}

void renderMotion_Free( RenderMotion* motion )
{
	free( motion->block );
	memset( motion, 0, sizeof( *motion ) );
}
