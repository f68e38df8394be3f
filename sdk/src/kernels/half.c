// The fp16 conversions every kernel shares (fp16 assets store their weights and blend shapes as IEEE halves). A file
// of their own, below every kernel: the dispatch table refers to the kernels, and the kernels convert with these.
#include "kernels.h"

#include <string.h>

float plHalfToFloat( uint16_t h )
{
	uint32_t sign = (uint32_t)( h & 0x8000u ) << 16;
	uint32_t exponent = ( h >> 10 ) & 0x1Fu;
	uint32_t mantissa = h & 0x3FFu;
	uint32_t bits;
	if ( exponent == 0 )
	{
		if ( mantissa == 0 )
		{
			bits = sign;
		}
		else
		{
			// Subnormal half: normalise into a float.
			int e = -1;
			do
			{
				e++;
				mantissa <<= 1;
			} while ( ( mantissa & 0x400u ) == 0 );
			bits = sign | ( (uint32_t)( 127 - 15 - e ) << 23 ) | ( ( mantissa & 0x3FFu ) << 13 );
		}
	}
	else if ( exponent == 31 )
	{
		bits = sign | 0x7F800000u | ( mantissa << 13 );
	}
	else
	{
		bits = sign | ( ( exponent + 127u - 15u ) << 23 ) | ( mantissa << 13 );
	}
	float f;
	memcpy( &f, &bits, sizeof( f ) );
	return f;
}

uint16_t plFloatToHalf( float f )
{
	uint32_t bits;
	memcpy( &bits, &f, sizeof( bits ) );
	uint32_t sign = ( bits >> 16 ) & 0x8000u;
	uint32_t exponent = ( bits >> 23 ) & 0xFFu;
	uint32_t mantissa = bits & 0x7FFFFFu;
	if ( exponent == 0xFFu )
	{
		return (uint16_t)( sign | 0x7C00u | ( mantissa ? 0x200u : 0u ) );
	}
	int e = (int)exponent - 127 + 15;
	if ( e >= 31 )
	{
		return (uint16_t)( sign | 0x7C00u );
	}
	if ( e <= 0 )
	{
		if ( e < -10 )
		{
			return (uint16_t)sign;
		}
		mantissa |= 0x800000u;
		uint32_t shift = (uint32_t)( 14 - e );
		uint32_t half = mantissa >> shift;
		uint32_t rest = mantissa & ( ( 1u << shift ) - 1u );
		uint32_t midpoint = 1u << ( shift - 1u );
		if ( rest > midpoint || ( rest == midpoint && ( half & 1u ) ) )
		{
			half++;
		}
		return (uint16_t)( sign | half );
	}
	uint32_t half = sign | ( (uint32_t)e << 10 ) | ( mantissa >> 13 );
	uint32_t rest = mantissa & 0x1FFFu;
	if ( rest > 0x1000u || ( rest == 0x1000u && ( half & 1u ) ) )
	{
		half++; // may carry into the exponent, which is the correct rounding
	}
	return (uint16_t)half;
}
