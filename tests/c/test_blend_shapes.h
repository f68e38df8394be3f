// Random blend shapes in each storage the kernels read (PLEAT_SHAPES_*), for the tests that hold the blend kernels to
// each other: the arrays, the plBlendShapes view of them and each element as the kernels read it (plShapeElement).
#ifndef PLEAT_TEST_BLEND_SHAPES_H
#define PLEAT_TEST_BLEND_SHAPES_H
#include "kernels/kernels.h"

#include <stdint.h>
#include <stdlib.h>

typedef struct plTestShapes
{
	plBlendShapes shapes; // what a kernel takes
	float* elements;      // [D][N][3] the elements as every kernel reads them (int8: q, the scale is the weight's)
	void* data;
	float* scales;
} plTestShapes;

// D shapes of `plane` elements of `type`, from rand() in [-1, 1) times `amplitude`; int8 shapes have a scale per
// shape that differs from shape to shape (and q spans −127..127).
static inline plTestShapes plTestShapes_Make( int type, uint32_t blend_count, size_t plane, float amplitude,
											  float ( *rand_unit )( void ) )
{
	size_t count = plane * blend_count;
	plTestShapes t;
	t.elements = (float*)malloc( count * sizeof( float ) );
	t.data = malloc( count * plShapeBytes( type ) );
	t.scales = type == PLEAT_SHAPES_I8 ? (float*)malloc( blend_count * sizeof( float ) ) : NULL;
	for ( uint32_t j = 0; j < blend_count; ++j )
	{
		if ( t.scales != NULL )
		{
			t.scales[j] = amplitude / 127.0f * ( 1.0f + 0.25f * (float)( j % 5 ) );
		}
		for ( size_t i = j * plane; i < ( j + 1 ) * plane; ++i )
		{
			float v = amplitude * rand_unit();
			if ( type == PLEAT_SHAPES_I8 )
			{
				int q = (int)( 127.0f * v / amplitude );
				( (int8_t*)t.data )[i] = (int8_t)( q < -127 ? -127 : q > 127 ? 127 : q );
			}
			else if ( type == PLEAT_SHAPES_F16 )
			{
				( (uint16_t*)t.data )[i] = plFloatToHalf( v );
			}
			else
			{
				( (float*)t.data )[i] = v;
			}
		}
	}
	t.shapes = ( plBlendShapes ){ t.data, type, t.scales };
	for ( uint32_t j = 0; j < blend_count; ++j )
	{
		for ( size_t i = j * plane; i < ( j + 1 ) * plane; ++i )
		{
			t.elements[i] = plShapeElement( &t.shapes, i );
		}
	}
	return t;
}

static inline void plTestShapes_Free( plTestShapes* t )
{
	free( t->elements );
	free( t->data );
	free( t->scales );
}

#endif
