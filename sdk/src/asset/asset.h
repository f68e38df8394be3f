// Internal: the asset object (docs/asset-format.md): loading (asset.c, with the container in asset_format.c, the
// sections and their meaning in asset_validate.c and the kernels' tables in asset_derive.c), lookup and the getters.
#ifndef PLEAT_ASSET_H
#define PLEAT_ASSET_H
#include "asset_data.h"
#include "asset_format.h"
#include "asset_validate.h"

// Looks up an asset handle (NULL if stale).
plAssetData* plGetAssetData( plAsset asset );

#endif
