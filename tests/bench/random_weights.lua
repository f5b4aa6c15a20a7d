-- wrk script: every request asks the mesh route for a new random point in FaceCap's face
-- space (4 random shapes, random weights), as float32, so the response cache cannot help.
local shapes = {"jawOpen", "mouthSmile_L", "mouthSmile_R", "eyeBlink_L", "eyeBlink_R", "browInnerUp",
                "cheekPuff", "mouthFunnel", "noseSneer_L", "mouthPucker", "jawLeft", "eyeWide_R"}
local counter = 0
function init(args)
  math.randomseed(os.time() + (tonumber(tostring({}):sub(8)) or 0))
end
request = function()
  counter = counter + 1
  local q, used = {}, {}
  while #q < 4 do
    local s = shapes[math.random(#shapes)]
    if not used[s] then
      used[s] = true
      q[#q + 1] = "w." .. s .. "=" .. string.format("%.5f", math.random() * 0.25)
    end
  end
  local path = "/v1/rigs/facecap/mesh?" .. table.concat(q, "&") .. "&format=f32"
  return wrk.format("GET", path)
end
