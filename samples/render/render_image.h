// Image helpers of the headless renderer: an RGB8 image, a tiny 5x7 bitmap font, PNG output and the contact sheet.
#ifndef PLEAT_RENDER_IMAGE_H
#define PLEAT_RENDER_IMAGE_H
#include <stdint.h>

typedef struct RenderImage
{
	int width;
	int height;
	uint8_t* rgb; // [height][width][3], top row first
} RenderImage;

int renderImage_Alloc( RenderImage* image, int width, int height );
void renderImage_Free( RenderImage* image );

// Draws text with the built-in 5x7 font (upper-case letters, digits, . , : / - + = ( ) _ % #; lower case is drawn
// as upper case, anything else as a blank) at pixel (x, y) = top-left, each font pixel scaled to scale x scale,
// on a darkened box so it reads on any background.
void renderImage_DrawText( RenderImage* image, int x, int y, int scale, const char* text );
int renderImage_TextWidth( const char* text, int scale );

// Box-filtered down-scale of src into the rectangle (x, y, w, h) of dst; w <= src width, h <= src height.
void renderImage_Blit( RenderImage* dst, int x, int y, int w, int h, const RenderImage* src );

// 8-bit RGB PNG through libpng; returns 0 on success.
int renderImage_WritePng( const RenderImage* image, const char* path );

#endif
