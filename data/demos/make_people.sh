#!/usr/bin/env bash
# Rebuilds data/demos/people.mcap: thirteen people of the CMU motion-capture database, each
# named (`sgplvm import --person`), retargeted onto WALK-MAN, COMAN and CENTAURO and split so
# that the test people are never in training (`retarget --split people`). It downloads each
# BVH file (pinned to a commit, checked by MD5) into a cache folder unless it is there already.
# Run from the repository root:
#
#     bash data/demos/make_people.sh [BVH_CACHE_DIR]      (default: target/people-bvh)
#
# The test people are fixed by a rule, before any model saw them: of the people sorted by
# their CMU subject number, every third (the 3rd, 6th, 9th, …) — 03, 07, 10 and 14. OUT=FILE
# writes elsewhere; RETARGET_ARGS adds flags to `sgplvm retarget`.
#
# Two conversions of the same database, two skeleton conventions: subjects 01–07 come from the
# Character Creator (Reallusion) conversion of the AMC files (DragonForgedTheArtist/IClone-CMU-Mocap:
# `CC_Base_*` bones, every bone along local y, a crooked line of bones at rest, 60 Hz), the
# others from B. Hahne's cgspeed BVH conversion (T-pose, 120 Hz). Each trial comes from one
# of them only.
#
# Needs curl (or the files already in the cache) and a built sgplvm (cargo builds it).
# The data: CMU Graphics Lab Motion Capture Database, http://mocap.cs.cmu.edu, "created with
# funding from NSF EIA-0196217". See data/demos/README.md.
set -euo pipefail
cd "$(dirname "$0")/../.."
cache=${1:-target/people-bvh}
out=${OUT:-data/demos/people.mcap}
rate=${RATE:-20}   # Hz: half the paper's 40, so that the shipped file stays small
mkdir -p "$cache"
cargo build --release --quiet --bin sgplvm
sgplvm=target/release/sgplvm
# shellcheck source=data/demos/fetch_bvh.sh
source data/demos/fetch_bvh.sh

# person | file stem | URL (a public copy, pinned to a commit) | MD5
trials=(
  "08|08_01|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/08/08_01.bvh|675930c3a3a0312c87785c8a667fb32b"
  "08|08_02|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/08/08_02.bvh|8711ef0762c9e72365ccecb577fb5d37"
  "08|08_03|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/08/08_03.bvh|c716a50db021448002c13bb718d6ebdc"
  "08|08_04|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/08/08_04.bvh|d8bcc847026ab0f34989e1bf25ed6c8b"
  "08|08_05|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/08/08_05.bvh|8bdcc3022950bac9fc0be9b3a3ffdfd4"
  "08|08_06|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/08/08_06.bvh|c1b15f3b7d9f5c428d0149eeeaf5682f"
  "08|08_07|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/08/08_07.bvh|749bcbd90334ee900add1ec2cff1c507"
  "08|08_08|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/08/08_08.bvh|8dd8bf0ae6ae6503a78c02a3b64d0ee4"
  "08|08_09|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/08/08_09.bvh|3ed63d487ee6ec22d6139a0b941d4c7b"
  "08|08_10|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/08/08_10.bvh|9b98a8d72db2dd3e18e663a79dfb7d92"
  "08|08_11|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/08/08_11.bvh|6a84d371890317de11a099f455df7e64"
  "09|09_01|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/09/09_01.bvh|d1f0cc63c30861437af4925601d0af97"
  "09|09_02|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/09/09_02.bvh|cd39f67cfa140d73d916de1db518b5f7"
  "09|09_03|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/09/09_03.bvh|524ca3e6ce1385fb9c65e1051aca5ce7"
  "09|09_04|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/09/09_04.bvh|8984634a987f5f68af94b1df41c01a62"
  "09|09_05|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/09/09_05.bvh|d195c34f528406c7517fdd13b29d9fd1"
  "09|09_06|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/09/09_06.bvh|764dbe8160a474b2d0214d11e990eb64"
  "09|09_07|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/09/09_07.bvh|7913eecb81331b262059ccec2bccdb1e"
  "09|09_08|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/09/09_08.bvh|f4bd0df31847f283713aa1bf728e33c7"
  "09|09_09|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/09/09_09.bvh|f2aba15c951452f5a5d9eaff0eda3c3d"
  "09|09_10|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/09/09_10.bvh|8380b089541f229daf097e5fca9b82b7"
  "09|09_11|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/09/09_11.bvh|7cd390b8399721ebbc00c1a1913c81f0"
  "10|10_04|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/10/10_04.bvh|e755008f38aa4448491c79d14cbe1454"
  "12|12_01|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/12/12_01.bvh|87e474dac6ffa711513f579f6e39c422"
  "12|12_02|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/12/12_02.bvh|5db36542b06716fb4177643900a6f9c8"
  "12|12_03|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/12/12_03.bvh|7030ff5ab16b6b21cb5b8bfccb6b0188"
  "13|13_10|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/13/13_10.bvh|3ac62c5fbb057ab43ae2772dfc9177d0"
  "13|13_11|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/13/13_11.bvh|69a4267cecb6535c8496feeecae4c4c0"
  "13|13_13|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/13/13_13.bvh|1f90e811d96ce32b42e6b26767b661ed"
  "13|13_26|https://raw.githubusercontent.com/gazebosim/gz-common/f4a6dbd1f30b0a3b0c11b067a4e3596384944d8a/test/data/cmu-13_26.bvh|edc0e3feac9a549dc7e6306effbf95e2"
  "13|13_29|https://raw.githubusercontent.com/GuiYi-Xi/monoform-previs-studio/daa54b2f6e78cc69f07102f7d32f6fabe3ac4a54/scripts/assets/CMU_13_29.bvh|7deac987ee2465f6fa8562493ddd88d2"
  "13|13_32|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/13/13_32.bvh|7d19122da746f6c0ee8bcaecb99d084e"
  "13|13_39|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/13/13_39.bvh|700ba259df46448e0b079778eb41fc68"
  "13|13_40|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/13/13_40.bvh|98a57e29590144353dba0424027ff9ad"
  "13|13_41|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/13/13_41.bvh|403c2c04e74b07fa1cfd4150cea4bc88"
  "13|13_42|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/13/13_42.bvh|a77f090ae2cec4cdcb35675ffb44420e"
  "14|14_07|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/14/14_07.bvh|63b7f5164569e0e26bde057bdce7d276"
  "14|14_08|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/14/14_08.bvh|3e21c434dadcf4350983ec40f4689615"
  "16|16_01|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/16/16_01.bvh|6716bd9fef424b772f72debc5e5eafe1"
  "16|16_02|https://raw.githubusercontent.com/Przestr/motion-capture/c200c31036a2b8cd2182ddbc85756b2dd79d70d2/data/16/16_02.bvh|3ab38e5a7931e7daeb1cb03b093b75a9"
  "01|ic_001_01|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/001/001_01.bvh|d849a8cdbcc434afece85b9bddbee2de"
  "01|ic_001_08|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/001/001_08.bvh|84c1afea2c0aecc522eec747575f2187"
  "01|ic_001_14|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/001/001_14.bvh|15075b0920e4ab5f11f0ba4497bb3dd9"
  "02|ic_002_01|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/002/002_01.bvh|dfbd920686122b84e92fc29b26e41df6"
  "02|ic_002_02|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/002/002_02.bvh|e9660ce24b7f475eacd08a76b8975648"
  "02|ic_002_03|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/002/002_03.bvh|fd9b273e3d792db8c1508dd9ca7a6b52"
  "02|ic_002_04|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/002/002_04.bvh|dd0f7c205e272f14069f1f427749019f"
  "02|ic_002_05|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/002/002_05.bvh|a3ab46edc29722de3fac3b119f3ff0e7"
  "02|ic_002_06|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/002/002_06.bvh|5c5cda67429c62876af977acfaa4b98b"
  "02|ic_002_07|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/002/002_07.bvh|6e0b557d46af0d8b60a06f8fc8f078a6"
  "02|ic_002_08|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/002/002_08.bvh|18a060022228a499571e3f071aa46193"
  "02|ic_002_09|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/002/002_09.bvh|1c08c78a412aa4376d9577fea84102b8"
  "02|ic_002_10|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/002/002_10.bvh|e4c00252acacb30b22f0998f52e91abf"
  "03|ic_003_01|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/003/003_01.bvh|e66209675fc33010812b7340fd319066"
  "03|ic_003_02|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/003/003_02.bvh|715bdc13faa2d25b21ce61578a287d67"
  "05|ic_005_01|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_01.bvh|5b68e872b79ed857a6cd9a27b588d46d"
  "05|ic_005_02|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_02.bvh|142595c7822f0e3e40f25549902be04c"
  "05|ic_005_03|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_03.bvh|4e7213e4542bb89b97b47dc907351790"
  "05|ic_005_04|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_04.bvh|01f85814988fced65ed3f4843060c38b"
  "05|ic_005_05|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_05.bvh|9e697829eb3504615b9d299b4c92e3df"
  "05|ic_005_06|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_06.bvh|d3004e7aaccdff221e9eec8f77166efb"
  "05|ic_005_07|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_07.bvh|dd6acfde421581cd307a65b0ef00d9b6"
  "05|ic_005_08|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_08.bvh|bec891495c5271b72fedf02bc6b62977"
  "05|ic_005_09|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_09.bvh|3339f66714df7a0a6170eef22f0abe84"
  "05|ic_005_10|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_10.bvh|2eb5dd97e94a39bd7dc06293c1fa2946"
  "05|ic_005_11|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_11.bvh|f3907b49b787a5a700c50df542d7e8e7"
  "05|ic_005_12|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_12.bvh|255c7c683ac74ae74d4f7c1e44143afd"
  "05|ic_005_13|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_13.bvh|eefe56a0a2ed62f621fa0580c0411e42"
  "05|ic_005_14|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_14.bvh|2a4fcade1e5f4538572af0625ce58c27"
  "05|ic_005_15|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_15.bvh|7bb3f0ce8e12a662a5b05cb1c3a3197a"
  "05|ic_005_16|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_16.bvh|44be8f013635d4d8ff19199d064ad089"
  "05|ic_005_17|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_17.bvh|6c0b534cfd177234b68f4f426b814b41"
  "05|ic_005_18|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_18.bvh|fe35bb3d3e5ecd22420ec8877766f406"
  "05|ic_005_19|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_19.bvh|f7bfa3caeedc02e64c8d2853bc282ca8"
  "05|ic_005_20|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/005/005_20.bvh|f9e9367ecfdda9439bbe87a54f28aab5"
  "06|ic_006_01|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_01.bvh|d9a01e1c8dbbd9f6b4f20d29f98f8672"
  "06|ic_006_02|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_02.bvh|b663cb4716c185eb6fb024e54ea4604d"
  "06|ic_006_03|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_03.bvh|ca9313de880db245b445631f39cd3b89"
  "06|ic_006_04|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_04.bvh|6e34bf42f0937f5b5edba501dc89f1f7"
  "06|ic_006_05|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_05.bvh|96bea43354008b9498f10edb817789f5"
  "06|ic_006_06|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_06.bvh|4b004c65d638506abfe26d9f7f09ab28"
  "06|ic_006_07|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_07.bvh|02796b67c13ca6b926c0742c1f39fe70"
  "06|ic_006_08|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_08.bvh|53181b05e2a3609a7e664efdaf387a8e"
  "06|ic_006_09|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_09.bvh|ce6786c6e4e5fc43e04700e86eb57f78"
  "06|ic_006_10|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_10.bvh|f1c52910ef7abbae32f6f4af36b34aec"
  "06|ic_006_11|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_11.bvh|c08bc9a18e789021546a684f449d4592"
  "06|ic_006_12|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_12.bvh|1151539b764a02b3be2c3f3a11ba2063"
  "06|ic_006_14|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_14.bvh|0663eec80723733cfb398a221ae2653c"
  "06|ic_006_15|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/006/006_15.bvh|6bd86075d64d1600b178eb5bfe7e8fd1"
  "07|ic_007_01|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/007/007_01.bvh|f6bf0aafa2a904b7307791721b3b4ea1"
  "07|ic_007_02|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/007/007_02.bvh|bbe926d2e86b205fb5304badd930013b"
  "07|ic_007_03|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/007/007_03.bvh|0225fa63f3fcf9c374e4822c3751ee65"
  "07|ic_007_04|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/007/007_04.bvh|437bd3636c372fff0221e837882d73bf"
  "07|ic_007_05|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/007/007_05.bvh|fca2a88f1f2c25aeab5bd5890ad07f9b"
  "07|ic_007_06|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/007/007_06.bvh|9a877bdd15940baba593e0922d5a3768"
  "07|ic_007_07|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/007/007_07.bvh|311a1f1a11091262a79ca79cdc186331"
  "07|ic_007_08|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/007/007_08.bvh|7045a8c83ef633083a8a101eea0cd713"
  "07|ic_007_09|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/007/007_09.bvh|7b35b91d9b19505b22572717f9e5f097"
  "07|ic_007_10|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/007/007_10.bvh|aa06a9c4bc3284452166d8f5404eb356"
  "07|ic_007_11|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/007/007_11.bvh|ca85e2888d9d2b25a7e146c2f57827ca"
  "07|ic_007_12|https://raw.githubusercontent.com/DragonForgedTheArtist/IClone-CMU-Mocap/79529f962ade3274163af53cd92179cee2ed9407/All_BVH/subjects/007/007_12.bvh|5a90fe719786daa6fdcc7e610eb4b009"
)

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
demos=()
people=()
for entry in "${trials[@]}"; do
  IFS='|' read -r person stem url md5 <<<"$entry"
  bvh="$cache/$stem.bvh"
  fetch_bvh "$bvh" "$url" "$md5"
  "$sgplvm" import "$bvh" --person "$person" --rate "$rate" --out "$work/$stem.mcap" >/dev/null 2>"$work/$stem.log" \
    || { cat "$work/$stem.log" >&2; exit 1; }
  demos+=(--demos "$work/$stem.mcap")
  people+=("$person")
done
# Every third person, by subject number.
test_people=$(printf '%s\n' "${people[@]}" | sort -un | awk 'NR % 3 == 0' | paste -sd,)
echo "test people (every third by subject number): $test_people"
# shellcheck disable=SC2086
"$sgplvm" retarget "${demos[@]}" --robots walkman,coman,centauro --out "$out" \
  --split people --test-people "$test_people" ${RETARGET_ARGS:-}
