// Image helpers of the headless renderer: a 5x7 bitmap font drawn by hand for this sample, PNG output via libpng,
// box-filtered down-scaling for the contact sheet.
#include "render_image.h"

#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int renderImage_Alloc( RenderImage* image, int width, int height )
{
	image->width = width;
	image->height = height;
	image->rgb = calloc( (size_t)width * (size_t)height, 3 );
	return image->rgb != NULL ? 0 : -1;
}

void renderImage_Free( RenderImage* image )
{
	free( image->rgb );
	image->rgb = NULL;
	image->width = image->height = 0;
}

// One glyph: 7 rows of 5 pixels, bit 4 = leftmost column.
typedef struct Glyph
{
	char character;
	uint8_t rows[7];
} Glyph;

static const Glyph s_font[] = {
	{ '0', { 0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E } },
	{ '1', { 0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E } },
	{ '2', { 0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F } },
	{ '3', { 0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E } },
	{ '4', { 0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02 } },
	{ '5', { 0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E } },
	{ '6', { 0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E } },
	{ '7', { 0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08 } },
	{ '8', { 0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E } },
	{ '9', { 0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C } },
	{ 'A', { 0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11 } },
	{ 'B', { 0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E } },
	{ 'C', { 0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E } },
	{ 'D', { 0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C } },
	{ 'E', { 0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F } },
	{ 'F', { 0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10 } },
	{ 'G', { 0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F } },
	{ 'H', { 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11 } },
	{ 'I', { 0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E } },
	{ 'J', { 0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C } },
	{ 'K', { 0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11 } },
	{ 'L', { 0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F } },
	{ 'M', { 0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11 } },
	{ 'N', { 0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11 } },
	{ 'O', { 0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E } },
	{ 'P', { 0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10 } },
	{ 'Q', { 0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D } },
	{ 'R', { 0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11 } },
	{ 'S', { 0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E } },
	{ 'T', { 0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04 } },
	{ 'U', { 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E } },
	{ 'V', { 0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04 } },
	{ 'W', { 0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A } },
	{ 'X', { 0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11 } },
	{ 'Y', { 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04, 0x04 } },
	{ 'Z', { 0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F } },
	{ '.', { 0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C } },
	{ ',', { 0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08 } },
	{ ':', { 0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00 } },
	{ '/', { 0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00 } },
	{ '-', { 0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00 } },
	{ '+', { 0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00 } },
	{ '=', { 0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00 } },
	{ '(', { 0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02 } },
	{ ')', { 0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08 } },
	{ '_', { 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F } },
	{ '%', { 0x19, 0x1A, 0x02, 0x04, 0x08, 0x0B, 0x13 } },
	{ '#', { 0x0A, 0x1F, 0x0A, 0x0A, 0x0A, 0x1F, 0x0A } },
};

enum
{
	GLYPH_W = 5,
	GLYPH_H = 7,
	GLYPH_ADVANCE = 6,
};

static const Glyph* findGlyph( char c )
{
	if ( c >= 'a' && c <= 'z' )
	{
		c = (char)( c - 'a' + 'A' );
	}
	for ( size_t i = 0; i < sizeof( s_font ) / sizeof( s_font[0] ); ++i )
	{
		if ( s_font[i].character == c )
		{
			return &s_font[i];
		}
	}
	return NULL;
}

int renderImage_TextWidth( const char* text, int scale )
{
	int n = (int)strlen( text );
	return n > 0 ? ( n * GLYPH_ADVANCE - 1 ) * scale : 0;
}

static void shadePixel( RenderImage* image, int x, int y, int numerator, int denominator )
{
	if ( x < 0 || y < 0 || x >= image->width || y >= image->height )
	{
		return;
	}
	uint8_t* p = image->rgb + ( (size_t)y * (size_t)image->width + (size_t)x ) * 3;
	for ( int c = 0; c < 3; ++c )
	{
		p[c] = (uint8_t)( p[c] * numerator / denominator );
	}
}

static void setPixel( RenderImage* image, int x, int y, uint8_t value )
{
	if ( x < 0 || y < 0 || x >= image->width || y >= image->height )
	{
		return;
	}
	uint8_t* p = image->rgb + ( (size_t)y * (size_t)image->width + (size_t)x ) * 3;
	p[0] = p[1] = p[2] = value;
}

void renderImage_DrawText( RenderImage* image, int x, int y, int scale, const char* text )
{
	int pad = scale * 2;
	int w = renderImage_TextWidth( text, scale );
	for ( int py = y - pad; py < y + GLYPH_H * scale + pad; ++py )
	{
		for ( int px = x - pad; px < x + w + pad; ++px )
		{
			shadePixel( image, px, py, 2, 5 );
		}
	}
	for ( int i = 0; text[i] != '\0'; ++i )
	{
		const Glyph* glyph = findGlyph( text[i] );
		if ( glyph == NULL )
		{
			continue;
		}
		int gx = x + i * GLYPH_ADVANCE * scale;
		for ( int row = 0; row < GLYPH_H; ++row )
		{
			for ( int col = 0; col < GLYPH_W; ++col )
			{
				if ( ( glyph->rows[row] >> ( GLYPH_W - 1 - col ) ) & 1 )
				{
					for ( int sy = 0; sy < scale; ++sy )
					{
						for ( int sx = 0; sx < scale; ++sx )
						{
							setPixel( image, gx + col * scale + sx, y + row * scale + sy, 245 );
						}
					}
				}
			}
		}
	}
}

void renderImage_Blit( RenderImage* dst, int x, int y, int w, int h, const RenderImage* src )
{
	for ( int ty = 0; ty < h; ++ty )
	{
		int sy0 = ty * src->height / h, sy1 = ( ty + 1 ) * src->height / h;
		for ( int tx = 0; tx < w; ++tx )
		{
			int sx0 = tx * src->width / w, sx1 = ( tx + 1 ) * src->width / w;
			unsigned sum[3] = { 0, 0, 0 }, count = 0;
			for ( int sy = sy0; sy < sy1; ++sy )
			{
				for ( int sx = sx0; sx < sx1; ++sx )
				{
					const uint8_t* p = src->rgb + ( (size_t)sy * (size_t)src->width + (size_t)sx ) * 3;
					sum[0] += p[0];
					sum[1] += p[1];
					sum[2] += p[2];
					++count;
				}
			}
			int dx = x + tx, dy = y + ty;
			if ( count == 0 || dx < 0 || dy < 0 || dx >= dst->width || dy >= dst->height )
			{
				continue;
			}
			uint8_t* d = dst->rgb + ( (size_t)dy * (size_t)dst->width + (size_t)dx ) * 3;
			for ( int c = 0; c < 3; ++c )
			{
				d[c] = (uint8_t)( ( sum[c] + count / 2 ) / count );
			}
		}
	}
}

int renderImage_WritePng( const RenderImage* image, const char* path )
{
	FILE* file = fopen( path, "wb" );
	if ( file == NULL )
	{
		return -1;
	}
	png_structp png = png_create_write_struct( PNG_LIBPNG_VER_STRING, NULL, NULL, NULL );
	png_infop info = png != NULL ? png_create_info_struct( png ) : NULL;
	if ( info == NULL || setjmp( png_jmpbuf( png ) ) )
	{
		png_destroy_write_struct( &png, &info );
		fclose( file );
		return -1;
	}
	png_init_io( png, file );
	png_set_compression_level( png, 9 );
	png_set_IHDR( png, info, (png_uint_32)image->width, (png_uint_32)image->height, 8, PNG_COLOR_TYPE_RGB,
				  PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT );
	png_write_info( png, info );
	for ( int y = 0; y < image->height; ++y )
	{
		png_write_row( png, image->rgb + (size_t)y * (size_t)image->width * 3 );
	}
	png_write_end( png, NULL );
	png_destroy_write_struct( &png, &info );
	return fclose( file ) == 0 ? 0 : -1;
}
