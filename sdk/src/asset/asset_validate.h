// Internal: what an asset's sections mean (docs/asset-format.md): the table of the sections every asset has, read
// through plReadSections, then the checks across them (counts, index ranges, joint order, the adjacency, skin rows,
// the networks' layer chain, the body contact, the embedded ONNX models).
#ifndef PLEAT_ASSET_VALIDATE_H
#define PLEAT_ASSET_VALIDATE_H
#include "asset_data.h"

#include <stddef.h>
#include <stdint.h>

// Validates data (structure, checksum unless skip_checksum, then content) and fills out; pointers point into data,
// which must be 64-byte aligned. Never reads outside [data, data + size). A rejection says which section it is about
// in out->rejected_detail. Exposed for tests and the fuzzer.
plResult plAssetData_Parse( const uint8_t* data, size_t size, int skip_checksum, plAssetData* out );

#endif
